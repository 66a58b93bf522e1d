#!/usr/bin/env bash
# The whole test suite: unit and command-line tests on an optimised build, again under AddressSanitizer +
# UndefinedBehaviorSanitizer (built with clang, with short runs of the four libFuzzer targets), the WebGPU backend's
# subset on llvmpipe (gpu/), a determinism check that builds at -Og (sanitized, clang), -O2 and -O3 (gcc) write
# byte-identical bundles (traces also with 1 and 2 threads), and that `meson install` gives a library a user's program
# builds against via pkg-config.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/deps.sh
trap 'rto_say "scripts/test.sh: line $LINENO failed: $BASH_COMMAND"' ERR
rto_install_deps
rto_install_debs "${RTO_TEST_DEBS[@]}"
# The sanitizer runs' options, for meson test and for the determinism check below. intercept_tls_get_addr=0: with
# it on, LeakSanitizer's runtime itself crashes at exit on some machines after a module with thread-local storage was
# loaded (google/sanitizers#1322); leak detection stays on (tests/sanitizer_leak.sh plants a leak and expects it).
# The symbolizer is llvm-14's (RTO_TEST_DEBS): without it, reports give addresses instead of function names.
symbolizer=/usr/lib/llvm-14/bin/llvm-symbolizer
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:intercept_tls_get_addr=0:external_symbolizer_path=$symbolizer
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:external_symbolizer_path=$symbolizer
t_start=$SECONDS
stage() { echo "== $* (at $((SECONDS - t_start)) s)"; }

stage "build (debugoptimized, -Werror)"
rto_build build --werror
# Three test processes on two cores: several tests spend part of their time waiting (signals sent after delays,
# timeouts, child processes), and a third keeps both cores busy through those waits.
meson test -C build --print-errorlogs --num-processes 3

# The gpu stage keeps about one core busy (a WebGPU dispatch, then rtoracle's check of it, in turn), so it runs in the
# background beside the sanitizer build and tests; its output is shown when they are done.
rto_install_gpu_deps
stage "gpu: the WebGPU kernels on Dawn (Mesa llvmpipe without a GPU), every dump checked by rtoracle (background)"
gpu_log=build/gpu-stage.log
# Its own process group (setsid), so that a failure elsewhere stops the whole of it, node included.
setsid bash tests/gpu.sh build/oracle/rtoracle build/gpu >"$gpu_log" 2>&1 &
gpu_pid=$!
tmp=
cleanup() {
    [ -z "$gpu_pid" ] || kill -- "-$gpu_pid" 2>/dev/null || true
    [ -z "$tmp" ] || rm -rf "$tmp"
}
trap cleanup EXIT

stage "build-asan (clang, address + undefined sanitizers, the fuzz targets)"
# clang, so that the same build holds the libFuzzer targets (-Dfuzz=targets), which the suite 'fuzz' runs a fixed
# number of times on their seed corpora; gcc builds the two others, and the determinism stage below holds the three
# to the same bytes. C at -Og (after meson's -O0, so it wins): the sanitizers' checks all stay, and the compute-heavy
# unit tests run about 1.5-2x faster than at -O0. The C++ glTF shim and image module stay at -O0: they compile twice
# as fast there. A build-asan configured otherwise (an older checkout's, with gcc) is made again.
if [ -f build-asan/build.ninja ] && ! meson introspect build-asan --buildoptions 2>/dev/null |
    python3 -c 'import json, sys; o = {x["name"]: x["value"] for x in json.load(sys.stdin)}; sys.exit(not (o.get("fuzz") == "targets" and o.get("bench") is False))'; then
    rm -rf build-asan
fi
# Line tables only (what the sanitizers' reports need) and lld: about a fifth less compile and link time.
CC=clang-14 CXX=clang++-14 rto_build build-asan --werror --buildtype=plain -Db_sanitize=address,undefined \
    -Db_lundef=false -Dfuzz=targets -Dbench=false "-Dc_args=-fno-sanitize-recover=all -Og -gline-tables-only" \
    "-Dcpp_args=-O0 -gline-tables-only" -Dc_link_args=-fuse-ld=lld -Dcpp_link_args=-fuse-ld=lld
# RTO_TEST_SANITIZED: the command-line tests' longest loops take a sample of their cases (every case class stays);
# the optimised build above ran them whole.
# golden (committed bundles, byte for byte) runs in the optimised build; here the same writers run under the
# sanitizers in the command-line tests, and the determinism stage holds this build's bundles to the others' bytes.
# The scripts suite (Python and shell alone, no rtoracle code) ran in the optimised build.
RTO_TEST_SANITIZED=1 meson test -C build-asan --print-errorlogs --num-processes 2 --no-suite golden --no-suite scripts

stage "gpu: waiting for the background run"
gpu_status=0
wait "$gpu_pid" || gpu_status=$?
gpu_pid=
cat "$gpu_log"
[ "$gpu_status" = 0 ] || { echo "FAIL: the gpu stage (tests/gpu.sh) exited $gpu_status (log: $gpu_log)" >&2; exit 1; }

stage "determinism across optimisation levels"
rto_build build-release --werror --buildtype=release -- installed
tmp=$(mktemp -d)
args=(suite sort --sizes tiny,tile,16384 --dists all --checkpoint-max 1024)
fix=fixtures
# determinism_runs BUILD: every bundle below written by BUILD's rtoracle; the three builds run side by side.
determinism_runs() {
    local b=$1 t set d
    "$b/oracle/rtoracle" "${args[@]}" -o "$tmp/$b" >/dev/null
    "$b/oracle/rtoracle" build "$fix/CornellBox-nvpro-glTF/cornellBox.gltf" -o "$tmp/$b/cornell" 2>/dev/null
    "$b/oracle/rtoracle" build "$fix/StanfordBunny/bunny.gltf" --tlas karras -o "$tmp/$b/bunny" 2>/dev/null
    "$b/oracle/rtoracle" build rtstress:12 -o "$tmp/$b/rtstress" 2>/dev/null
    # Traces with 1 and 2 threads: every ray set, both TLAS layouts, a fixture with a camera and the bunny.
    for t in 1 2; do
        "$b/oracle/rtoracle" trace "$fix/CornellBox-nvpro-glTF/cornellBox.gltf" --rays shadow --width 96 --height 72 \
            --threads $t -o "$tmp/$b/trace-cornell-$t" 2>/dev/null
        "$b/oracle/rtoracle" trace "$fix/StanfordBunny/bunny.gltf" --rays primary --width 96 --height 72 \
            --tlas karras --threads $t -o "$tmp/$b/trace-bunny-$t" 2>/dev/null
        for set in random grazing axis; do
            "$b/oracle/rtoracle" trace rtstress:6 --rays $set --count 20000 --threads $t \
                -o "$tmp/$b/trace-rtstress-$set-$t" 2>/dev/null
        done
        # Frames: a textured fixture through both bounces of sun-shadow, and seed 002's analytic scene.
        "$b/oracle/rtoracle" render "$fix/Duck/glTF/Duck.gltf" --program sun-shadow --width 96 --height 72 --stages all \
            --threads $t -o "$tmp/$b/frame-duck-$t" >/dev/null 2>&1
        "$b/oracle/rtoracle" render stage2 --program normals --width 96 --height 72 --stages all --threads $t \
            -o "$tmp/$b/frame-stage2-$t" >/dev/null
    done
    for d in "$tmp/$b"/trace-*-1 "$tmp/$b"/frame-*-1; do
        diff -r "$d" "${d%-1}-2" >/dev/null || { echo "FAIL: $d differs between 1 and 2 threads" >&2; return 1; }
    done
}
pids=()
for b in build build-asan build-release; do
    determinism_runs "$b" &
    pids+=($!)
done
for p in "${pids[@]}"; do
    wait "$p" || { echo "FAIL: the determinism runs of one build failed (above)" >&2; exit 1; }
done
diff -r "$tmp/build" "$tmp/build-asan" >/dev/null && diff -r "$tmp/build" "$tmp/build-release" >/dev/null || {
    echo "FAIL: bundles differ between optimisation levels" >&2
    exit 1
}
echo "determinism: $(grep -c '"case"' "$tmp/build/manifest.json") sort cases, 3 build bundles, 5 trace bundles and 2 frame bundles byte-identical at -Og/asan (clang), -O2 and -O3 (gcc) and with 1 and 2 threads"
stage "install: a user's program built against the installed library through pkg-config"
bash tests/install.sh build-release
echo "== all tests passed in $((SECONDS - t_start)) s"

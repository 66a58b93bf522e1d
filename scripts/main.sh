#!/usr/bin/env bash
# The main job: install what is missing, build everything, and write the golden bundles to out/goldens/.
#   bash scripts/main.sh [extra arguments for `rtoracle suite sort`]
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/deps.sh
rto_install_deps
rto_install_gpu_deps
rto_build build --werror
out=out/goldens
mkdir -p "$out"
# Loader warnings go to a temporary file outside out/: a run that changes nothing writes nothing there.
err=$(mktemp)
trap 'rm -f "$err"' EXIT
# Every command below leaves a bundle that is already up to date alone (same inputs, options and rtoracle build, no
# file changed since; README "Re-running the main job"), so a second run rewrites nothing.
# The sort matrix a GPU harness runs: every distribution x size class x format x algorithm (about 700 MB).
build/oracle/rtoracle suite sort -o "$out/sort" "$@"
# Acceleration-structure bundles of every bundled fixture scene and the procedural scenes.
fix=fixtures
mkdir -p "$out/build"
while IFS= read -r f; do
    name=$(basename "${f%.*}")
    # Loader warnings (e.g. CornellBox's unused texture) are not news here; a failure shows them and stops.
    build/oracle/rtoracle build "$f" -o "$out/build/$name" 2>"$err" || { cat "$err" >&2; exit 1; }
done < <(find "$fix" \( -name '*.gltf' -o -name '*.glb' \) | sort)
for spec in triangle rtstress:16 instances:clustered:4097; do
    build/oracle/rtoracle build "$spec" -o "$out/build/${spec//:/-}"
done
# Trace bundles: primary and shadow rays at 320x240 through every fixture scene and the procedural ones (the
# inputs of a GPU's TRACE kernel and the hit records it must write).
mkdir -p "$out/trace"
while IFS= read -r f; do
    name=$(basename "${f%.*}")
    for set in primary shadow; do
        build/oracle/rtoracle trace "$f" --rays $set --width 320 --height 240 -o "$out/trace/$name-$set" \
            2>"$err" || { cat "$err" >&2; exit 1; }
    done
done < <(find "$fix" \( -name '*.gltf' -o -name '*.glb' \) | sort)
for spec in triangle rtstress:16; do
    build/oracle/rtoracle trace "$spec" --rays primary --width 320 --height 240 -o "$out/trace/${spec//:/-}-primary"
done
# Frame bundles: one wavefront frame per scene with a fitting program (every queue, hit, counter, indirect argument,
# accum buffer and image a GPU's frame must produce), one summary line each.
mkdir -p "$out/frame"
while IFS= read -r f; do
    name=$(basename "${f%.*}")
    build/oracle/rtoracle render "$f" --program sun-shadow --width 320 --height 240 --no-timings \
        -o "$out/frame/$name-sun-shadow" 2>"$err" || { cat "$err" >&2; exit 1; }
done < <(find "$fix" \( -name '*.gltf' -o -name '*.glb' \) | sort)
build/oracle/rtoracle render triangle --program triangle --width 320 --height 240 --no-timings -o "$out/frame/triangle"
build/oracle/rtoracle render rtstress:16 --program sun-shadow --width 320 --height 240 --no-timings \
    -o "$out/frame/rtstress-16-sun-shadow"
build/oracle/rtoracle render stage2 --program normals --width 320 --height 240 --no-timings -o "$out/frame/stage2"
echo "rtoracle: built build/oracle/rtoracle; golden bundles in $out/"

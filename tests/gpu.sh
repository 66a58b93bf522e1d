#!/usr/bin/env bash
# The WebGPU backend's test: gpu/run's ci subset (every sort kernel over every distribution at 1, 2, 255-257, 4096
# and 4097 keys, one TLAS build, one traced frame of triangle and of sun-shadow at 64x64 on rtstress:4, the
# visibility buffer of triangle and rtstress:2 at 64x48, 1x and 4x MSAA, normals and lambert, and the Duck unlit at 4x,
# its texture sampled, three fluid splats of 16^3 and 24^3 voxels and the raymarch of a fourth, 48x36, with and
# without empty-space skipping) must pass,
# and each planted fault must be reported by the oracle as the fault it is, where it starts; gpu/probe's filtering
# measurement must find llvmpipe within the raymarch envelope's filter model, and a value moved out of it.
#   bash tests/gpu.sh RTORACLE OUTDIR
set -euo pipefail
rto=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
out=$(realpath "$out") # absolute: meson install --destdir and the moved cases below take it from other directories
run() { gpu/run --rtoracle "$rto" "$@"; }

# One line per case goes to ci.log; the device and the summary are printed, the whole log only on a failure.
gpu/run --rtoracle "$rto" --subset ci --json "$out/ci.json" --html "$out/ci.html" >"$out/ci.log" 2>&1 ||
    { cat "$out/ci.log" >&2; echo "FAIL: gpu/run --subset ci (log: $out/ci.log)" >&2; exit 1; }
grep -E '^device:|cases pass' "$out/ci.log"
echo "gpu: the ci subset passes ($out/ci.html, one line per case in $out/ci.log)"
# Dawn's start-up notes are not in the log (gpu/run drops the two it prints on OpenGL; Vulkan is not tried without its
# loader), and a sort case is named, and its directory under --out is named, as rtoracle suite sort names its bundle.
! grep -q '^Warning:' "$out/ci.log" || { grep '^Warning:' "$out/ci.log" >&2; echo "FAIL: Dawn's warnings in the log" >&2; exit 1; }
run --families radix --dists clustered --sizes 257 --out "$out/named" >"$out/named.log" 2>&1 &&
    grep -q '^radix-u32-clustered-n257 .* pass 1/1' "$out/named.log" && [ -f "$out/named/radix-u32-clustered-n257/keys.npy" ] ||
    { cat "$out/named.log" >&2; ls "$out/named" >&2; echo "FAIL: the sort case's name and directory" >&2; exit 1; }
echo "gpu: no Dawn start-up warnings; sort cases named as suite sort names them, directories too"

# expect_fault NAME CHECK FAULT DIAGNOSIS-REGEX [gpu/run arguments...]: the run fails (status 1) with exactly one
# failing case, whose first failing check, fault class and diagnosis are the expected ones.
expect_fault() {
    local name=$1 check=$2 fault=$3 diag=$4 status=0
    shift 4
    run "$@" --json "$out/$name.json" >"$out/$name.log" 2>&1 || status=$?
    [ "$status" = 1 ] || { cat "$out/$name.log" >&2; echo "FAIL: $name: gpu/run exited $status, not 1" >&2; exit 1; }
    node -e '
        const [file, check, fault, diag] = process.argv.slice(1);
        const bad = require(file).results.filter((r) => !r.pass);
        const r = bad[0] || {};
        if (bad.length !== 1 || r.check !== check || r.fault !== fault || !new RegExp(diag).test(r.diagnosis)) {
          console.error(`expected one failing case with ${check} / ${fault} / ${diag}; got ${bad.length}: ` +
            `${r.check} / ${r.fault} / ${r.diagnosis}`);
          process.exit(1);
        }' "$(realpath "$out/$name.json")" "$check" "$fault" "$diag" || { echo "FAIL: $name" >&2; exit 1; }
    echo "gpu: $name: $(node -e 'const r = require(process.argv[1]).results.find((x) => !x.pass);
        console.log(`${r.case}: ${r.check}: ${r.diagnosis}`)' "$(realpath "$out/$name.json")")"
}

# A user's own kernel through --kernels: a bitonic pass with its comparison turned round orders every pair the wrong
# way from the first pass on.
mkdir -p "$out/kernels"
sed 's/(ascending \&\& a > b) || (!ascending \&\& a < b)/(ascending \&\& a < b) || (!ascending \&\& a > b)/' \
    gpu/kernels/bitonic_pass.wgsl >"$out/kernels/bitonic_pass.wgsl"
! cmp -s gpu/kernels/bitonic_pass.wgsl "$out/kernels/bitonic_pass.wgsl" || { echo "FAIL: the planted kernel" >&2; exit 1; }
expect_fault kernels-override check-sort order 'first diverge at pass 0 \(k=2, j=1\)' \
    --families bitonic --dists random --sizes 4096 --kernels "$out/kernels"

# --racy-scatter: tile invocations claim output slots with an atomicAdd on a per-digit cursor, in whatever order they
# arrive, so equal digits leave input order from the first pass on (all-zero keys but one make it visible at once).
expect_fault racy-scatter check-sort pass '^pass: radix pass 0 \(digit bits 0\.\.3\) is the first to diverge' \
    --families radix --dists entropy-15 --sizes 256 --racy-scatter

# --drop-barrier 10: pass 11 of the one-workgroup network may read slots pass 10 has not written yet (or pass 10 slots
# pass 11 already rewrote): the first diverging checkpoint is pass 10 or 11, never earlier, never later.
expect_fault drop-barrier check-sort pass '^pass: checkpoint pass 1[01] \(k=32, j=(16|8)\) is the first to diverge' \
    --families bitonic-wg --dists sorted --sizes 4096 --drop-barrier 10

# The fluid splat (seed 003): a contribution rounded instead of truncated, an occupancy mip that leaves out each
# parent's last child (single: the particle at the centre sets one child of parent (1, 1, 1), the last) and a resolve
# 0.1 % off are each caught and named by check-volume.
mkdir -p "$out/fluid-round" "$out/fluid-mip" "$out/fluid-resolve"
sed 's/atomicAdd(&vol\[i\], u32(k \* params.scale));/atomicAdd(\&vol[i], u32(k * params.scale + 0.5));/' \
    gpu/kernels/fluid_splat.wgsl >"$out/fluid-round/fluid_splat.wgsl"
sed 's/for (var c = 0u; c < 8u; c++) {/for (var c = 0u; c < 7u; c++) {/' gpu/kernels/fluid_occupancy.wgsl \
    >"$out/fluid-mip/fluid_occupancy.wgsl"
sed 's|f32(u) / params.scale, 0.0|f32(u) / params.scale * 1.001, 0.0|' gpu/kernels/fluid_resolve.wgsl \
    >"$out/fluid-resolve/fluid_resolve.wgsl"
for f in fluid-round/fluid_splat fluid-mip/fluid_occupancy fluid-resolve/fluid_resolve; do
    ! cmp -s "gpu/kernels/${f#*/}.wgsl" "$out/$f.wgsl" || { echo "FAIL: the planted $f" >&2; exit 1; }
done
expect_fault fluid-round check-volume contribution '^contribution: voxel \([0-9]+, [0-9]+, [0-9]+\) holds ' \
    --families fluid --scenes dambreak:2000 --kernels "$out/fluid-round"
expect_fault fluid-mip check-volume occupancy '^occupancy: level 1 cell \(1, 1, 1\) is 0, but the OR of its children' \
    --families fluid --scenes single --kernels "$out/fluid-mip"
expect_fault fluid-resolve check-volume resolve '^resolve: voxel ' \
    --families fluid --scenes splash:1000 --kernels "$out/fluid-resolve"
# The raymarch's empty-space skipping made to jump from an occupied cell too (its level-0 test left out): the skipping
# march of the ci subset's dambreak case takes fewer steps than the samples lying in occupied cells, named as skip.
mkdir -p "$out/fluid-skip"
sed 's/  if (occ_get(0u, c.x, c.y, c.z)) { return k; }/  if (false) { return k; }/' gpu/kernels/fluid_raymarch.wgsl \
    >"$out/fluid-skip/fluid_raymarch.wgsl"
! cmp -s gpu/kernels/fluid_raymarch.wgsl "$out/fluid-skip/fluid_raymarch.wgsl" || { echo "FAIL: the planted skip" >&2; exit 1; }
expect_fault fluid-skip check-raymarch skip '^skip at pixel \([0-9]+, [0-9]+\): [0-9]+ steps with skipping' \
    --families fluid --subset ci --kernels "$out/fluid-skip"

# The filtering probe (gpu/probe): llvmpipe's trilinear filtering fits the raymarch envelope's model (DESIGN.md
# §12.5.1); one result moved by 2/256 of its texels' spread (beyond the model's 1.69/256) is counted outside it.
node gpu/probe/probe.mjs "$out/probe" >"$out/probe.log" 2>&1 && python3 gpu/probe/filter.py "$out/probe" >>"$out/probe.log" ||
    { cat "$out/probe.log" >&2; echo "FAIL: gpu/probe on llvmpipe" >&2; exit 1; }
python3 - "$out/probe/filterA.f32" <<'PY'
import struct, sys
path = sys.argv[1]
b = bytearray(open(path, 'rb').read())
v = struct.unpack_from('<f', b, 0)[0]  # query 0, R: the sweep's first weight (texels 0 and 1 in x: spread 1)
struct.pack_into('<f', b, 0, v + 2.0 / 256)
open(path, 'wb').write(b)
PY
status=0
python3 gpu/probe/filter.py "$out/probe" >"$out/probe-bad.log" 2>&1 || status=$?
[ "$status" = 1 ] && grep -q '^texture A: .* 1 outside the model$' "$out/probe-bad.log" ||
    { cat "$out/probe-bad.log" >&2; echo "FAIL: a filtered value 2/256 off not counted (status $status)" >&2; exit 1; }
echo "gpu: llvmpipe's filtering fits the raymarch envelope's model; a value 2/256 of its spread off does not"

# Bad usage: one line, status 2.
for args in "--repeat 0" "--families nope" "--subset most" "--kernels /nonexistent" "--check-only" \
    "--families radix --sweep pow2:26" "--families radix --sweep tile:x" "--sweep n:5-9"; do
    status=0
    # shellcheck disable=SC2086
    run $args >"$out/usage.log" 2>&1 || status=$?
    [ "$status" = 2 ] && [ "$(wc -l <"$out/usage.log")" = 1 ] ||
        { cat "$out/usage.log" >&2; echo "FAIL: gpu/run $args: status $status, not one line and 2" >&2; exit 1; }
done
echo "gpu: bad usage gets one line and status 2"

# The pattern across failing cases (gpu/lib/patterns.js) on made-up rows: a size rule, a distribution, a shared stage.
node --input-type=module -e '
    import {patterns} from "./gpu/lib/patterns.js";
    const row = (n, pass, dist = "random") => ({family: "radix", params: {size: n, dist}, pass,
        check: pass ? null : "check-sort", fault: pass ? null : "pass",
        diagnosis: pass ? "" : `pass: radix pass 0 is the first to diverge at slot ${n - 3}`});
    const want = (rows, re) => { const p = patterns(rows);
        if (p.length !== 1 || !re.test(p[0])) { console.error(`patterns: ${JSON.stringify(p)} !~ ${re}`); process.exit(1); } };
    want([row(256, true), row(257, false), row(512, true), row(300, false), row(4097, false)],
        /^radix: 3 of 5 cases fail; fails only when n % 256 != 0; first bad check always check-sort pass: pass: radix pass # is the first to diverge at slot #$/);
    want([row(256, true), row(512, true), row(4096, false), row(8192, false)], /fails only above n = 512 \(from n = 4096\)/);
    want([row(256, true, "sorted"), row(256, false, "clustered"), row(512, false, "clustered"), row(512, true, "sorted")],
        /fails only for clustered/);
    if (patterns([row(256, true), row(257, false)]).length) process.exit(1); // one failure: its own diagnosis
' || { echo "FAIL: gpu/lib/patterns.js" >&2; exit 1; }
echo "gpu: patterns across failing cases named (size rule, distribution, shared stage)"

# A size sweep (keys made on the fly, check-sort --input) with a histogram kernel whose partial last tile loses its
# last key (only with more than one tile): 250-256 pass, it fails exactly from 257 on, the summary says so per size,
# and --shrink takes each failure down to 257. (llvmpipe passes the bundled kernels over tile:256,pow2:22:
# docs/results/llvmpipe-sweep.json.)
rm -rf "$out/tail" && mkdir -p "$out/tail"
sed 's/  for (var i = tile \* TILE + t; i < min(p.n, (tile + 1u) \* TILE); i += WG) {/  let end = select(p.n, p.n - 1u, tile > 0u \&\& p.n % TILE != 0u);\n  for (var i = tile * TILE + t; i < min(end, (tile + 1u) * TILE); i += WG) {/' \
    gpu/kernels/radix_hist.wgsl >"$out/tail/radix_hist.wgsl"
! cmp -s gpu/kernels/radix_hist.wgsl "$out/tail/radix_hist.wgsl" || { echo "FAIL: the planted tail tile" >&2; exit 1; }
status=0
run --families radix --sweep n:250-262 --shrink --kernels "$out/tail" --json "$out/tail.json" >"$out/tail.log" 2>&1 ||
    status=$?
[ "$status" = 1 ] && grep -q "^sweep radix/random: 7 of 13 sizes pass; failing n: 257-262$" "$out/tail.log" &&
    node -e 'const s = require(process.argv[1]); const bad = s.results.filter((r) => !r.pass);
        process.exit(bad.length === 6 && bad.every((r) => r.shrunk && r.shrunk.size === 257) &&
            s.sweeps[0].failing.join() === "257,258,259,260,261,262" ? 0 : 1)' "$(realpath "$out/tail.json")" ||
    { cat "$out/tail.log" >&2; echo "FAIL: the planted tail-tile bug (status $status)" >&2; exit 1; }
echo "gpu: a tail-tile bug: $(grep "^sweep" "$out/tail.log"), shrunk to 257"

# The dump-there / check-here flow of a GPU host: cases prepared here and moved to another path, dumped there, then
# checked by an installed rtoracle copied to another prefix (its own image module beside it; it links no Embree).
build=$(dirname "$(dirname "$(realpath "$rto")")")
rm -rf "$out/host-root" "$out/host" "$out/prep"
meson install -C "$build" --destdir "$out/host-root" --no-rebuild --quiet >"$out/host-install.log" 2>&1 ||
    { cat "$out/host-install.log" >&2; echo "FAIL: meson install" >&2; exit 1; }
prefix=$(meson introspect "$build" --buildoptions |
    python3 -c 'import json,sys; print([o["value"] for o in json.load(sys.stdin) if o["name"]=="prefix"][0])')
cp -a "$out/host-root$prefix" "$out/host"
rm -rf "$out/host-root"
run --families trace,frame --subset ci --prepare-only --out "$out/prep" >"$out/host.log" 2>&1 &&
    mv "$out/prep" "$out/host/cases" &&
    gpu/run --families trace,frame --subset ci --dump-only --out "$out/host/cases" >>"$out/host.log" 2>&1 &&
    gpu/run --rtoracle "$out/host/bin/rtoracle" --families trace,frame --subset ci --check-only \
        --out "$out/host/cases" >>"$out/host.log" 2>&1 &&
    ! ldd "$out/host/bin/rtoracle" | grep -qi embree ||
    { cat "$out/host.log" >&2; echo "FAIL: the moved prepared cases checked by the installed rtoracle" >&2; exit 1; }
echo "gpu: cases prepared here, moved, dumped, checked by a relocated installed rtoracle: $(grep "cases pass" "$out/host.log")"

# A user's kernel under a name no bundled kernel has is refused (it would be ignored and the run pass): status 2, one
# line listing the names.
rm -rf "$out/misnamed" && mkdir -p "$out/misnamed"
cp gpu/kernels/radix_hist.wgsl "$out/misnamed/radix-hist.wgsl"
status=0
run --families radix --kernels "$out/misnamed" >"$out/misnamed.log" 2>&1 || status=$?
[ "$status" = 2 ] && [ "$(wc -l <"$out/misnamed.log")" = 1 ] && grep -q "radix-hist.wgsl names no bundled kernel; the kernels are .*radix_hist.wgsl" "$out/misnamed.log" ||
    { cat "$out/misnamed.log" >&2; echo "FAIL: a misnamed kernel: status $status" >&2; exit 1; }
echo "gpu: a misnamed kernel is refused: $(cut -c1-100 "$out/misnamed.log")..."

# A kernel that does not compile is a setup error: status 2, its first WGSL error once (file and line), no verdict.
rm -rf "$out/broken" && mkdir -p "$out/broken"
awk 'NR == 5 { print "fn broken( {" } { print }' gpu/kernels/radix_common.wgsl >"$out/broken/radix_common.wgsl"
status=0
run --families radix --dists random --sizes 4096 --kernels "$out/broken" >"$out/broken.log" 2>&1 || status=$?
[ "$status" = 2 ] && [ "$(grep -c "error:" "$out/broken.log")" = 1 ] &&
    grep -q "^gpu/run: .*/broken/radix_common.wgsl:5:12: error: " "$out/broken.log" &&
    ! grep -qE " (pass|FAIL) [0-9]+/[0-9]+" "$out/broken.log" ||
    { cat "$out/broken.log" >&2; echo "FAIL: a kernel that does not compile: status $status" >&2; exit 1; }
echo "gpu: $(grep "^gpu/run:" "$out/broken.log")"

# A barrier made conditional passes on llvmpipe, which executes it anyway: the report says llvmpipe cannot show that
# (text and JSON); on a GPU it would be a race.
rm -rf "$out/barrier" && mkdir -p "$out/barrier"
sed 's/^    storageBarrier();/    if (kj.y == 1u) { storageBarrier(); }/' gpu/kernels/bitonic_wg.wgsl >"$out/barrier/bitonic_wg.wgsl"
! cmp -s gpu/kernels/bitonic_wg.wgsl "$out/barrier/bitonic_wg.wgsl" || { echo "FAIL: the planted barrier" >&2; exit 1; }
run --families bitonic-wg --dists random --sizes 4096 --kernels "$out/barrier" --json "$out/barrier.json" \
    >"$out/barrier.log" 2>&1 || true
if grep -q "^device: opengl" "$out/barrier.log"; then
    grep -q "^warning: llvmpipe cannot show barrier races: bitonic_wg.wgsl uses barriers" "$out/barrier.log" &&
        node -e 'const s = require(process.argv[1]);
            process.exit(s.warnings.length === 1 && /llvmpipe cannot show barrier races/.test(s.warnings[0]) &&
                s.user_kernels.length === 1 ? 0 : 1)' "$(realpath "$out/barrier.json")" ||
        { cat "$out/barrier.log" >&2; echo "FAIL: no llvmpipe barrier warning" >&2; exit 1; }
    echo "gpu: a conditional barrier on llvmpipe: $(grep "cases pass" "$out/barrier.log")"
fi

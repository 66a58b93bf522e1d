#!/usr/bin/env bash
# Command-line tests of splat and check-volume. splat: the bundle's files and manifest, the same bytes with 1, 2 and 3
# threads, a positions file splatted like the generator it came from, overflow written with a warning, bad options
# and inputs (a truncated .npy, another dtype or shape, a non-finite position) refused with one line. check-volume: a
# bundle's own arrays pass in every dump shape a harness may write (flat, uint16 bit patterns, rgba, no f16 plane, no
# occupancy grid), binary16 truncation passes by default and is named under --f16-rounding nearest; a changed voxel,
# a voxel beyond every radius given mass, a cleared occupancy word are each named; a tampered bundle, a mistyped or
# missing dump array is refused with status 2 and one line. Under the sanitizers (RTO_TEST_SANITIZED) the lists of
# refused inputs take every other case.
set -u
RTO=$1
EDIT=$2     # tests/tools/bundle_edit.c
VD=$3       # tests/tools/volume_dump.c
. "$(dirname "$0")/cli_lib.sh"

run 0 "$RTO" splat --help && has "usage: rtoracle splat" out && has "volume_u32.npy" out
run 0 "$RTO" check-volume --help && has "usage: rtoracle check-volume" out && has "resolve-rounding" out
run 0 "$RTO" --help && has "check-volume" out && has "splat" out

# bad usage and input: one line, exit 2, nothing written
printf 'not an npy' >"$T/junk.npy"
k=0
for args in "single" "rain:5 -o $T/x" "dambreak:0 -o $T/x" "dambreak:16777217 -o $T/x" "single --resolution 0 -o $T/x" \
    "single --resolution 8,8 -o $T/x" "single --resolution 1025 -o $T/x" "single --radius 0 -o $T/x" \
    "single --scale 0 -o $T/x" "single --scale 1e9 -o $T/x" "single --bounds 0,0,0,1,1 -o $T/x" \
    "single --bounds 1,0,0,0,1,1 -o $T/x" "single --occupancy 0 -o $T/x" "single --radius 1e-30 -o $T/x" \
    "$T/missing.npy -o $T/x" "$T/junk.npy -o $T/x" "single --resolution 1024 -o $T/x" \
    "dambreak:200000 --radius 1.5 --resolution 256 -o $T/x"; do
    k=$((k + 1))
    [ $(((k - 1) % $(sampled 2))) = 0 ] || continue   # under the sanitizers every other case
    run 2 "$RTO" splat $args || continue
    [ "$(wc -l <"$T/err")" = 1 ] || fail "splat $args: want one stderr line: $(cat "$T/err")"
    [ -e "$T/x" ] && fail "splat $args left $T/x"
done

# a bundle: files, manifest, the same bytes for 1, 2 and 3 threads
run 0 "$RTO" splat dambreak:4000 --resolution 32,28,36 --radius 0.12 --occupancy 16 --threads 1 -o "$T/b" &&
    has "^splat dambreak:4000: 4000 particles into 32x28x36 voxels" out
for f in fluid_params.npy particles.npy volume_u32.npy volume_f16.npy occupancy.npy manifest.json; do
    [ -f "$T/b/$f" ] || fail "the bundle lacks $f"
done
[ -e "$T/b/overflow.npy" ] && fail "overflow.npy without overflow"
grep -q '"level_4_res": 1' "$T/b/manifest.json" && grep -q '"voxels_nonzero": ' "$T/b/manifest.json" ||
    fail "manifest: no occupancy levels or splat statistics"
for t in 2 3; do
    run 0 "$RTO" splat dambreak:4000 --resolution 32,28,36 --radius 0.12 --occupancy 16 --threads $t -o "$T/b$t"
    diff -r "$T/b" "$T/b$t" >/dev/null || fail "splat: the bundle differs between 1 and $t threads"
done
run 0 "$RTO" splat dambreak:4000 --resolution 32,28,36 --radius 0.12 --occupancy 16 -o "$T/b" && has "up to date" out

# a positions file: the generator's particles give the generator's volume; bad files refused with one line
cp "$T/b/particles.npy" "$T/p.npy"
run 0 "$RTO" splat "$T/p.npy" --resolution 32,28,36 --radius 0.12 --occupancy 16 -o "$T/pf"
cmp -s "$T/b/volume_u32.npy" "$T/pf/volume_u32.npy" && cmp -s "$T/b/occupancy.npy" "$T/pf/occupancy.npy" ||
    fail "splat of the positions file differs from the generator's"
head -c 150 "$T/p.npy" >"$T/trunc.npy"
cp "$T/p.npy" "$T/nan.npy" && "$EDIT" "$T/nan.npy" set-f32 7 nan >/dev/null
cp "$T/p.npy" "$T/inf.npy" && "$EDIT" "$T/inf.npy" set-f32 0 -inf >/dev/null
cp "$T/p.npy" "$T/u32.npy" && "$EDIT" "$T/u32.npy" as-u32 >/dev/null
cp "$T/p.npy" "$T/flat.npy" && "$VD" flat "$T/flat.npy"
for f in trunc nan inf u32 flat; do
    run 2 "$RTO" splat "$T/$f.npy" --resolution 16 -o "$T/x" || continue
    [ "$(wc -l <"$T/err")" = 1 ] || fail "splat $f.npy: want one stderr line: $(cat "$T/err")"
    [ -e "$T/x" ] && fail "splat $f.npy left $T/x"
done

# check-volume: the bundle's own arrays pass in each shape a harness may write
mkdir -p "$T/d"
cp "$T/b/volume_u32.npy" "$T/b/volume_f16.npy" "$T/b/occupancy.npy" "$T/d/"
run 0 "$RTO" check-volume --expected "$T/b" --gpu "$T/d" && has "^PASS" out
run 0 "$RTO" check-volume --expected "$T/b" --gpu "$T/d" --f16-rounding nearest --json --threads 1 && has '"fault": "none"' out
cp -r "$T/d" "$T/d2"
"$VD" flat "$T/d2/volume_u32.npy" && "$VD" as-u16 "$T/d2/volume_f16.npy" && "$VD" rgba "$T/d2/volume_f16.npy"
run 0 "$RTO" check-volume --expected "$T/b" --gpu "$T/d2" --f16-rounding nearest
rm "$T/d2/volume_f16.npy" "$T/d2/occupancy.npy"
run 0 "$RTO" check-volume --expected "$T/b" --gpu "$T/d2"
cp -r "$T/d" "$T/rtz" && "$VD" rtz "$T/rtz" 1000
run 0 "$RTO" check-volume --expected "$T/b" --gpu "$T/rtz"
run 1 "$RTO" check-volume --expected "$T/b" --gpu "$T/rtz" --f16-rounding nearest --json &&
    has '"fault": "resolve-rounding"' out

# mutations, each named: a voxel changed where mass is (contribution), mass far from every particle (radius; the
# dambreak block leaves the box's far corner empty), a cleared occupancy word (occupancy)
v=$(( (18 * 28 + 6) * 32 + 5 ))   # inside the block: x 5, y 6, z 18
cp -r "$T/d" "$T/m1"
old=$("$EDIT" "$T/m1/volume_u32.npy" set-u32 $v 0)
new=$(( ${old##* } + 100000 ))
"$EDIT" "$T/m1/volume_u32.npy" set-u32 $v $new >/dev/null
run 1 "$RTO" check-volume --expected "$T/b" --gpu "$T/m1" --json && has '"fault": "contribution"' out && loc x 5 &&
    loc z 18
cp -r "$T/d" "$T/m2"
"$EDIT" "$T/m2/volume_u32.npy" set-u32 $(( 32 * 28 * 36 - 1 )) 7 >/dev/null
run 1 "$RTO" check-volume --expected "$T/b" --gpu "$T/m2" && has "^FAIL radius" out
# the report does not depend on --threads
run 1 "$RTO" check-volume --expected "$T/b" --gpu "$T/m2" --json --threads 1 && cp "$T/out" "$T/r1"
run 1 "$RTO" check-volume --expected "$T/b" --gpu "$T/m2" --json --threads 3 && cmp -s "$T/out" "$T/r1" ||
    fail "check-volume: the report differs between 1 and 3 threads"
cp -r "$T/d" "$T/m3"
"$EDIT" "$T/m3/occupancy.npy" set-u32 0 0 >/dev/null
run 1 "$RTO" check-volume --expected "$T/b" --gpu "$T/m3" --json && has '"fault": "occupancy"' out

# overflow: written with a warning (exit 0); the bundle's own volume is still a fault
run 0 "$RTO" splat dambreak:300 --resolution 16 --radius 0.3 --scale 16777216 -o "$T/ov" &&
    has "overflow 32 bits" err && [ -f "$T/ov/overflow.npy" ] || fail "no overflow warning or list"
mkdir -p "$T/dov" && cp "$T/ov/volume_u32.npy" "$T/dov/"
run 1 "$RTO" check-volume --expected "$T/ov" --gpu "$T/dov" --json && has '"fault": "overflow"' out

# refused: a tampered bundle, a mistyped, transposed or missing dump array, a missing directory
cp -r "$T/b" "$T/tb"
"$EDIT" "$T/tb/volume_u32.npy" set-u32 $v 1 >/dev/null
cp -r "$T/b" "$T/tb2" && "$EDIT" "$T/tb2/particles.npy" set-f32 30 0.5 >/dev/null
cp -r "$T/b" "$T/tb3" && "$EDIT" "$T/tb3/fluid_params.npy" set-f32 3 0.13 >/dev/null
cp -r "$T/b" "$T/tb4" && "$EDIT" "$T/tb4/fluid_params.npy" set-f32 12 32.5 >/dev/null
cp -r "$T/b" "$T/tb5" && "$EDIT" "$T/tb5/occupancy.npy" set-u32 3 0 >/dev/null
cp -r "$T/d" "$T/bad1" && "$EDIT" "$T/bad1/volume_f16.npy" as-u32 >/dev/null
cp -r "$T/d" "$T/bad2" && cp "$T/b/particles.npy" "$T/bad2/volume_u32.npy"
mkdir -p "$T/bad3" && cp "$T/b/volume_f16.npy" "$T/bad3/"
cp -r "$T/d" "$T/bad4" && head -c 100 "$T/d/volume_u32.npy" >"$T/bad4/volume_u32.npy"
for args in "--expected $T/tb --gpu $T/d" "--expected $T/tb2 --gpu $T/d" "--expected $T/tb3 --gpu $T/d" \
    "--expected $T/tb4 --gpu $T/d" "--expected $T/tb5 --gpu $T/d" "--expected $T/b --gpu $T/bad1" "--expected $T/b --gpu $T/bad2" \
    "--expected $T/b --gpu $T/bad3" "--expected $T/b --gpu $T/bad4" "--expected $T/b --gpu $T/none" \
    "--expected $T/none --gpu $T/d" "--expected $T/b --gpu $T/d --f16-rounding up" "--expected $T/b"; do
    k=$((k + 1))
    [ $(((k - 1) % $(sampled 2))) = 0 ] || continue
    run 2 "$RTO" check-volume $args || continue
    [ "$(wc -l <"$T/err")" = 1 ] || fail "check-volume $args: want one stderr line: $(cat "$T/err")"
done

finish "cli.fluid: ok"

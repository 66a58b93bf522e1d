#!/usr/bin/env bash
# Command-line tests of raymarch and check-raymarch (DESIGN.md §12.4-§12.7). raymarch: the bundle's files and
# manifest (skipping lossless: 0 differing pixels, fewer steps), the same bytes with 1 and 3 threads, bad options and
# inputs refused with one line and status 2. check-raymarch: a dump made of the bundle's own buffers passes; each
# mutation (a certain pixel's colour, a crossing's step, a skipping GPU's steps or crossings, a plane's shape) is
# named with its fault class and status 1; a tampered bundle, a missing or mistyped dump plane are refused with 2.
set -u
RTO=$1
. "$(dirname "$0")/cli_lib.sh"

# npy_poke FILE INDEX VALUE f4|u4 : sets element INDEX of a little-endian f32 / u32 .npy (version 1 header).
npy_poke() {
    python3 - "$@" <<'PY'
import struct, sys
path, idx, val, kind = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
b = bytearray(open(path, 'rb').read())
hl = struct.unpack_from('<H', b, 8)[0]
off = 10 + hl + 4 * idx
struct.pack_into('<f' if kind == 'f4' else '<I', b, off, float(val) if kind == 'f4' else int(val))
open(path, 'wb').write(b)
PY
}
# npy_get FILE INDEX f4|u4|u1 : prints element INDEX.
npy_get() {
    python3 - "$@" <<'PY'
import struct, sys
path, idx, kind = sys.argv[1], int(sys.argv[2]), sys.argv[3]
b = open(path, 'rb').read()
hl = struct.unpack_from('<H', b, 8)[0]
sz = {'f4': 4, 'u4': 4, 'u1': 1}[kind]
print(struct.unpack_from({'f4': '<f', 'u4': '<I', 'u1': '<B'}[kind], b, 10 + hl + sz * idx)[0])
PY
}
# first_pixel RMDIR : a certain pixel with a crossing (its index).
first_pixel() {
    python3 - "$1" <<'PY'
import struct, sys
def arr(p, fmt, sz):
    b = open(p, 'rb').read(); hl = struct.unpack_from('<H', b, 8)[0]; d = b[10 + hl:]
    return [struct.unpack_from(fmt, d, i)[0] for i in range(0, len(d), sz)]
c = arr(sys.argv[1] + '/rm_crossing.npy', '<I', 4)
k = arr(sys.argv[1] + '/rm_certain.npy', '<B', 1)
s = arr(sys.argv[1] + '/rm_steps_skip.npy', '<I', 4)
print(next(i for i in range(len(c)) if c[i] != 0xFFFFFFFF and k[i] and s[i] > 0))
PY
}

run 0 "$RTO" raymarch --help && has "usage: rtoracle raymarch SPLATDIR" out && has "rm_steps_skip.npy" out
run 0 "$RTO" check-raymarch --help && has "usage: rtoracle check-raymarch" out && has "crossing_noskip.npy" out
run 0 "$RTO" --help && has "check-raymarch" out

run 0 "$RTO" splat dambreak:2000 --resolution 32 --radius 0.1 -o "$T/sp"
W=64
H=48
[ -n "${RTO_TEST_SANITIZED:-}" ] && W=32 && H=24

# bad usage and input: one line, exit 2, nothing written
for args in "$T/sp" "$T/sp --width 0 -o $T/x" "$T/sp --multiplier 0 -o $T/x" "$T/missing -o $T/x" \
    "$T/sp --camera 1,2,3 -o $T/x" "$T/sp --camera 0,0,0,0,0,0,0,1,0,60 -o $T/x" "$T/sp --refractions 17 -o $T/x" \
    "$T/sp --jitter 2 -o $T/x" "$T/sp --width 5000 -o $T/x" "$T/sp --width 4096 --height 4096 -o $T/x"; do
    run 2 "$RTO" raymarch $args || continue
    [ "$(wc -l <"$T/err")" = 1 ] || fail "raymarch $args: want one stderr line: $(cat "$T/err")"
    [ -e "$T/x" ] && fail "raymarch $args left $T/x"
done

# a bundle: files, manifest (skipping lossless), the same bytes with 1 and 3 threads
run 0 "$RTO" raymarch "$T/sp" --width $W --height $H --threads 1 -o "$T/rm" &&
    has "^raymarch $T/sp: ${W}x${H}" out && has " 0 differing pixels, 0 differing crossings" out
for f in rm_params.npy rm_image.npy image.png rm_crossing.npy rm_crossing_t.npy rm_normal_central.npy \
    rm_normal_forward.npy rm_steps.npy rm_steps_skip.npy rm_certain.npy rm_tolerance.npy fluid_params.npy \
    volume_f16.npy occupancy.npy manifest.json; do
    [ -f "$T/rm/$f" ] || fail "the bundle lacks $f"
done
grep -q '"differing_pixels": 0' "$T/rm/manifest.json" && grep -q '"steps_skip_mean": ' "$T/rm/manifest.json" ||
    fail "manifest: no differing_pixels 0 or steps_skip_mean"
python3 -c 'import json, sys; s = json.load(open(sys.argv[1]))["stats"]; sys.exit(not s["steps_skip_mean"] < s["steps_mean"])' \
    "$T/rm/manifest.json" || fail "skipping did not reduce the steps"
run 0 "$RTO" raymarch "$T/sp" --width $W --height $H --threads 3 -o "$T/rm3"
for f in "$T"/rm/*.npy; do cmp -s "$f" "$T/rm3/$(basename "$f")" || fail "$(basename "$f") differs between 1 and 3 threads"; done
# --no-skip: the same image, steps_skip = steps
run 0 "$RTO" raymarch "$T/sp" --width $W --height $H --no-skip -o "$T/rmn"
cmp -s "$T/rm/rm_image.npy" "$T/rmn/rm_image.npy" || fail "--no-skip changed the image"
cmp -s "$T/rmn/rm_steps.npy" "$T/rmn/rm_steps_skip.npy" || fail "--no-skip: steps_skip differs from steps"
# Up to date: the same request on the same splat is not recomputed (--threads is no input); another splat's volume in
# the same directory, or --force, writes it again.
run 0 "$RTO" raymarch "$T/sp" --width $W --height $H --no-skip --threads 2 -o "$T/rmn" && has "is up to date" out
run 0 "$RTO" raymarch "$T/sp" --width $W --height $H --no-skip --force -o "$T/rmn" && has "differing pixels" out
run 0 "$RTO" splat dambreak:2000 --resolution 32 --radius 0.11 -o "$T/sp2"
cp "$T/sp2/volume_f16.npy" "$T/sp/volume_f16.npy.new" && mv "$T/sp/volume_f16.npy.new" "$T/sp/volume_f16.npy"
run 2 "$RTO" raymarch "$T/sp" --width $W --height $H --no-skip -o "$T/rmn"
rm -rf "$T/sp" && cp -r "$T/sp2" "$T/sp"
run 0 "$RTO" raymarch "$T/sp" --width $W --height $H --no-skip -o "$T/rmn" && has "differing pixels" out

# check-raymarch: the bundle's own buffers pass
mkdir -p "$T/d"
cp "$T/rm/rm_image.npy" "$T/d/image.npy"
cp "$T/rm/rm_crossing.npy" "$T/d/crossing.npy"
cp "$T/rm/rm_steps.npy" "$T/d/steps.npy"
cp "$T/rm/rm_steps_skip.npy" "$T/d/steps_skip.npy"
run 0 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/d" && has "check-raymarch: PASS" out
P=$(first_pixel "$T/rm")
X=$((P % W))
Y=$((P / W))

mutate() { rm -rf "$T/m"; cp -r "$T/d" "$T/m"; }
# image: a certain pixel's red channel moved by 0.25
mutate
v=$(npy_get "$T/m/image.npy" $((4 * P)) f4)
npy_poke "$T/m/image.npy" $((4 * P)) "$(python3 -c "print($v + 0.25)")" f4
run 1 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m" && has "FAIL image at pixel ($X, $Y)" out
# crossing: the step 40 samples later
mutate
c=$(npy_get "$T/m/crossing.npy" $P u4)
npy_poke "$T/m/crossing.npy" $P $((c + 40)) u4
run 1 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m" && has "FAIL crossing at pixel ($X, $Y)" out
# skip: no steps at a pixel with a crossing (its samples in occupied cells skipped)
mutate
npy_poke "$T/m/steps_skip.npy" $P 0 u4
run 1 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m" && has "FAIL skip at pixel ($X, $Y)" out
# skip: the GPU's crossing without skipping differs from its crossing with
mutate
cp "$T/m/crossing.npy" "$T/m/crossing_noskip.npy"
npy_poke "$T/m/crossing_noskip.npy" $P $((c + 1)) u4
run 1 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m" && has "FAIL skip at pixel ($X, $Y)" out
# shape: another image size
run 0 "$RTO" raymarch "$T/sp" --width 8 --height 6 --no-envelope -o "$T/small"
mutate
cp "$T/small/rm_image.npy" "$T/m/image.npy"
run 1 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m" && has "FAIL shape" out

# refused with one line and 2: a missing crossing plane, a mistyped one, a tampered bundle, no bundle
mutate
rm "$T/m/crossing.npy"
run 2 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m" && has "crossing.npy: missing" err
mutate
cp "$T/rm/rm_crossing_t.npy" "$T/m/crossing.npy"
run 2 "$RTO" check-raymarch --expected "$T/rm" --gpu "$T/m"
run 2 "$RTO" check-raymarch --expected "$T/missing" --gpu "$T/d"
rm -rf "$T/tam"
cp -r "$T/rm" "$T/tam"
npy_poke "$T/tam/rm_image.npy" 0 0.5 f4
run 2 "$RTO" check-raymarch --expected "$T/tam" --gpu "$T/d" && [ "$(wc -l <"$T/err")" = 1 ] ||
    fail "a tampered bundle: not one line: $(cat "$T/err")"
run 2 "$RTO" check-raymarch --gpu "$T/d"
[ "$(wc -l <"$T/err")" -le 2 ] || fail "check-raymarch without --expected: $(cat "$T/err")"

finish "cli.raymarch: all passed"

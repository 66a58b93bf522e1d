#!/bin/bash
# rtoracle compare: idiff's exit statuses on images made here by tests/tools/images.py (Python standard library
# only, never rtoracle's writer): identical images pass (0); a 1-pixel shift, swapped channels, an inverted channel
# and a gamma change fail (2); small noise within the fail threshold warns (1); --json is valid JSON; --diff writes
# the difference (checked pixel by pixel with the script's own PNG decoder); bad input exits 2 with one line.
# Each run loads OpenImageIO (~0.3 s): the cases are chosen to cover each rule once.
RTO=$1
IMAGES=$2
. "$(dirname "$0")/cli_lib.sh"
cd "$T" || exit 1

python3 "$IMAGES" set . || { echo "images.py set failed"; exit 1; }

# Identical images pass; an 8-bit PNG and the same values in a float OpenEXR compare in [0, 1] units.
run 0 "$RTO" compare base.png base.png && has PASS out && has "PSNR        inf" out
run 0 "$RTO" compare base.png base.exr && has PASS out

# Each kind of fault fails, even with thresholds loose enough for the noise below.
for p in shift swap-rb invert-g gamma; do
    run 2 "$RTO" compare base.png "$p.png" --fail 0.01 --warn 0.001 --fail-percent 1 && has FAILURE out
done
# Noise of 1/255 in one channel of every 7th pixel: within --fail 0.01, over --warn 0.001 -> WARNING.
run 1 "$RTO" compare base.png noise.png --fail 0.01 --warn 0.001 && has WARNING out
has "28 pixels (14.6 %) over the warn threshold 0.001" out
has "0 pixels (0 %) over the fail threshold 0.01" out
# ... within both -> PASS; with the defaults (any difference) -> FAILURE; a hard limit under 1/255 -> FAILURE.
run 0 "$RTO" compare base.png noise.png --fail 0.01 --warn 0.01 && has PASS out
run 2 "$RTO" compare base.png noise.png
run 2 "$RTO" compare base.png noise.png --fail-percent 15 --warn-percent 15 --hard-fail 0.003

# One channel of pixel (3, 2) off by 5/255: the max error, where it is, and the diff image (x 10 -> 50 / 255).
run 2 "$RTO" compare base.png one-off.png --diff diff.png --diff-scale 10 &&
    has "max error   0.0196078 at pixel (3, 2), channel 2 (B)" out
got=$(python3 "$IMAGES" pixel diff.png 3 2 0 0 15 11 | tr '\n' '/')
[ "$got" = "0 0 50 255/0 0 0 255/0 0 0 255/" ] || fail "diff.png pixels: $got"
run 2 "$RTO" compare base.exr one-off.exr --diff diff.exr && [ -s diff.exr ] || fail "no diff.exr"
ls ./*.tmp.* >/dev/null 2>&1 && fail "a temporary was left behind"
# --diff naming an input (by another path too) is refused before anything is read or written; the input is intact.
cp base.png base.keep
for out in base.png ./base.png one-off.png; do
    run 2 "$RTO" compare base.png one-off.png --diff "$out" && has "refusing to write $out: it is the input" err
    [ "$(wc -l <"$T/err")" = 1 ] || fail "--diff $out: more than one line on stderr"
done
cmp -s base.png base.keep || fail "compare --diff base.png changed the input base.png"

# Sizes from the headers, before any pixel is decoded: a PNG whose header says 16384 x 16384 RGBA (1 GiB decoded)
# and an EXR that says 16384 x 16384 RGBA float (4 GiB), their pixel data stubs (decoding would fail), are refused by
# the budget, and against a small image by their size, each in under a second and 300 MB.
python3 "$(dirname "$0")/big_image.py" big.png 16384 16384
python3 "$(dirname "$0")/big_image.py" big.exr 16384 16384
bounded 2 "compare big.png base.png" "$RTO" compare big.png base.png && has "differ in size" err
bounded 2 "compare base.png big.png" "$RTO" compare base.png big.png && has "differ in size" err
bounded 2 "compare big.png big.png" "$RTO" compare big.png big.png &&
    has "16384x16384 with 4 channels of 8 bits needs 1024 MiB decoded, over the budget of 256 MiB" err
bounded 2 "compare big.exr big.exr" "$RTO" compare big.exr big.exr &&
    has "16384x16384 with 4 channels of float needs 4096 MiB decoded, over the budget of 256 MiB" err

# --json: one valid JSON object with the figures, the location and the verdict (PSNR inf as the string "inf").
run 2 "$RTO" compare base.png one-off.png --json && cp "$T/out" one-off.json
run 0 "$RTO" compare base.png base.png --json && cp "$T/out" same.json
python3 - one-off.json same.json <<'EOF' || fail "--json output"
import json, math, sys
r = json.load(open(sys.argv[1]))
n, d = 16 * 12 * 4, 5 / 255
assert r["verdict"] == "fail" and r["exit_status"] == 2, r
assert r["max_error_at"] == {"x": 3, "y": 2, "channel": 2, "channel_name": "B"}, r["max_error_at"]
assert abs(r["max_error"] - d) < 1e-7 and abs(r["mean_error"] - d / n) < 1e-7, r
assert abs(r["rms_error"] - d / math.sqrt(n)) < 1e-7, r
assert abs(r["psnr"] - 20 * math.log10(math.sqrt(n) / d)) < 1e-3, r
assert r["fail_count"] == 1 and r["warn_count"] == 1 and r["pixels"] == 16 * 12, r
s = json.load(open(sys.argv[2]))
assert s["psnr"] == "inf" and s["verdict"] == "pass" and s["exit_status"] == 0, s
EOF

# Bad input: exit 2, one line on stderr, nothing on stdout.
bad() {
    run 2 "$RTO" compare "$@" || return
    [ "$(wc -l <"$T/err")" = 1 ] || { fail "not one line on stderr: $*"; sed 's/^/    | /' "$T/err"; }
    [ -s "$T/out" ] && fail "stdout written: $*"
}
bad base.png missing.png && has "missing.png" err
bad base.png cut.png && has "'cut.png': corrupt PNG" err
bad cut.exr base.exr && has "cut.exr" err
mkfifo fifo.png
bad base.png fifo.png && has "not a regular file" err
mkdir dir.png
bad dir.png base.png && has "is a directory" err
printf 'not an image at all' >junk.png
bad junk.png base.png && has "junk.png" err
bad base.png base3.png && has "base.png is 16x12 with 4 channels, base3.png is 16x12 with 3 channels" err
bad base.png wide.png && has "wide.png is 17x12" err
bad base.png base.png --diff diff.bmp && has "diff.bmp" err
bad base.png base.png --fail -1
bad base.png base.png --fail nan
bad base.png base.png --fail-percent 101
bad base.png
RTO_IMAGE_MODULE=/etc/hostname bad base.png base.png && has "/etc/hostname" err

finish "cli.compare: ok"

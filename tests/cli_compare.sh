#!/bin/bash
# rtoracle compare: idiff's exit statuses on images made here by tests/tools/images.py (Python standard library
# only, never rtoracle's writer): identical images pass (0); a 1-pixel shift, swapped channels, an inverted channel
# and a gamma change fail (2); noise with a few failing pixels tolerated by --fail-percent warns (1); images of
# different sizes or channel counts are compared over both (2); --json is valid JSON; --diff writes the difference
# (checked pixel by pixel with the script's own PNG decoder); input that cannot be compared exits 4 with one line.
# Where Debian's idiff is installed (openimageio-tools), every exit status is checked against idiff's on the same
# files and thresholds.
# Each run loads OpenImageIO (~0.3 s): the cases are chosen to cover each rule once.
RTO=$1
IMAGES=$2
. "$(dirname "$0")/cli_lib.sh"
cd "$T" || exit 1

python3 "$IMAGES" set . || { echo "images.py set failed"; exit 1; }

# Identical images pass; an 8-bit PNG and the same values in a float OpenEXR compare in [0, 1] units.
run 0 "$RTO" compare base.png base.png && has PASS out && has "PSNR        inf" out
run 0 "$RTO" compare base.png base.exr && has PASS out

# Each kind of fault fails, even with thresholds loose enough for the noise below. The verdict's arithmetic on more
# threshold pairs runs in the optimised build only: under the sanitizers each run costs 0.7 s of OpenImageIO loading,
# and the same comparisons run there in unit.image (rto_image_compare); the runs that read, write or refuse files all
# stay.
for p in shift swap-rb invert-g gamma; do
    run 2 "$RTO" compare base.png "$p.png" --fail 0.01 --warn 0.001 --fail-percent 1 && has FAILURE out
    [ -z "${RTO_TEST_SANITIZED:-}" ] || break
done
# Noise of 1/255 in one channel of every 7th pixel: 28 pixels over --fail 0.003, tolerated by --fail-percent 20, and
# over --warn 0.001 -> WARNING.
run 1 "$RTO" compare base.png noise.png --fail 0.003 --fail-percent 20 --warn 0.001 && has WARNING out
has "28 pixels (14.6 %) over the warn threshold 0.001" out
has "28 pixels (14.6 %) over the fail threshold 0.003" out
# ... within --fail 0.01 everywhere -> PASS, whatever --warn says (idiff 2.4.7: a warning needs a failing pixel);
# with the defaults (any difference) -> FAILURE; a hard limit under 1/255 -> FAILURE.
if [ -z "${RTO_TEST_SANITIZED:-}" ]; then
    run 0 "$RTO" compare base.png noise.png --fail 0.01 --warn 0.001 && has PASS out
    run 0 "$RTO" compare base.png noise.png --fail 0.01 --warn 0.01 && has PASS out
    run 2 "$RTO" compare base.png noise.png
    run 2 "$RTO" compare base.png noise.png --fail-percent 15 --warn-percent 15 --hard-fail 0.003
fi

# One channel of pixel (3, 2) off by 5/255: the max error, where it is, and the diff image (x 10 -> 50 / 255).
run 2 "$RTO" compare base.png one-off.png --diff diff.png --diff-scale 10 &&
    has "max error   0.0196078 at pixel (3, 2), channel 2 (B); values are .* vs " out
got=$(python3 "$IMAGES" pixel diff.png 3 2 0 0 15 11 | tr '\n' '/')
[ "$got" = "0 0 50 255/0 0 0 255/0 0 0 255/" ] || fail "diff.png pixels: $got"
run 2 "$RTO" compare base.exr one-off.exr --diff diff.exr && [ -s diff.exr ] || fail "no diff.exr"
ls ./*.tmp.* >/dev/null 2>&1 && fail "a temporary was left behind"
# --diff naming an input (by another path too) is refused before anything is read or written; the input is intact.
cp base.png base.keep
for out in base.png ./base.png one-off.png; do
    run 4 "$RTO" compare base.png one-off.png --diff "$out" && has "refusing to write $out: it is the input" err
    [ "$(wc -l <"$T/err")" = 1 ] || fail "--diff $out: more than one line on stderr"
done
cmp -s base.png base.keep || fail "compare --diff base.png changed the input base.png"

# Sizes from the headers, before any pixel is decoded: a PNG whose header says 16384 x 16384 RGBA (1 GiB decoded)
# and an EXR that says 16384 x 16384 RGBA float (4 GiB), their pixel data stubs (decoding would fail), are refused by
# the budget (exit 4), alone or against a small image, each in under a second and 300 MB.
python3 "$(dirname "$0")/big_image.py" big.png 16384 16384
python3 "$(dirname "$0")/big_image.py" big.exr 16384 16384
bounded 4 "compare big.png base.png" "$RTO" compare big.png base.png && has "over the budget of 256 MiB" err
bounded 4 "compare base.png big.png" "$RTO" compare base.png big.png && has "over the budget of 256 MiB" err
bounded 4 "compare big.png big.png" "$RTO" compare big.png big.png &&
    has "16384x16384 with 4 channels of 8 bits needs 1024 MiB decoded, over the budget of 256 MiB" err
bounded 4 "compare big.exr big.exr" "$RTO" compare big.exr big.exr &&
    has "16384x16384 with 4 channels of float needs 4096 MiB decoded, over the budget of 256 MiB" err

# Different sizes or channel counts: compared over both, a missing value reading as 0 (idiff's way): FAILURE, with
# a note on stderr and no diff image.
run 2 "$RTO" compare base.png base3.png --diff d3.png && has "FAILURE" out && has "differ in size (16x12 with 4" err
[ -e d3.png ] && fail "a diff image of images of different channel counts"
run 2 "$RTO" compare base.png wide.png && has "values are none vs" out

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

# Input that cannot be compared: exit 4 (idiff's code for a file it cannot read; 2 is FAILURE), one line on stderr,
# nothing on stdout.
bad() {
    run 4 "$RTO" compare "$@" || return
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
bad base.png base.png --diff diff.bmp && has "diff.bmp" err
bad base.png base.png --fail -1
bad base.png base.png --fail nan
bad base.png base.png --fail-percent 101
bad base.png
RTO_IMAGE_MODULE=/etc/hostname bad base.png base.png && has "/etc/hostname" err

# Debian's idiff on the same files: identical, warning, failure, size and channel mismatches, a missing file, and a
# brightness change of 1 % under five threshold pairs; compare's exit status must equal idiff's. RGB images: idiff
# reads a PNG with alpha as premultiplied (OpenImageIO's default), compare reads the stored values, so the two agree
# on images whose alpha is 1 (every image rtoracle writes) and may differ elsewhere. A truncated PNG is a file compare
# cannot read (4); idiff 2.4.7 compares whatever libpng left in the buffer (2).
# (In the optimised build: the sanitized run covers the same code with the cases above.)
if command -v idiff >/dev/null && [ -z "${RTO_TEST_SANITIZED:-}" ]; then
    same_as_idiff() { # EXPECTED ACTUAL [options as compare spells them]
        local a=$1 b=$2 idiff_args
        shift 2
        idiff_args=$(printf '%s ' "$@" | sed 's/--fail-percent/-failpercent/g; s/--warn-percent/-warnpercent/g;
            s/--hard-fail/-hardfail/g; s/--hard-warn/-hardwarn/g; s/--fail/-fail/g; s/--warn/-warn/g')
        # shellcheck disable=SC2086
        idiff $idiff_args "$a" "$b" >/dev/null 2>&1
        local want=$?
        run "$want" "$RTO" compare "$a" "$b" "$@" || fail "compare $a $b $*: idiff says $want"
        compared=$((compared + 1))
    }
    compared=0
    same_as_idiff base3.png base3.png
    same_as_idiff base3.png noise3.png --fail 0.003 --fail-percent 20 --warn 0.001
    same_as_idiff base3.png noise3.png --fail 0.01 --warn 0.001
    same_as_idiff base3.png noise3.png --fail 0.003 --fail-percent 20 --warn 0.001 --warn-percent 20
    same_as_idiff base3.png shift3.png
    same_as_idiff base.png wide.png
    same_as_idiff base.png base3.png
    same_as_idiff base3.png missing.png
    for th in "0.008 0.004" "0.01 0.001" "0.02 0.01"; do
        set -- $th
        same_as_idiff base3.png bright3.png --fail "$1" --warn "$2"
    done
    echo "compare's exit status equals $(idiff --version 2>&1 | head -1 | tr -d '\n')'s on $compared cases"
fi

finish "cli.compare: ok"

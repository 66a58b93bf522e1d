#!/usr/bin/env bash
# Command-line tests of check-frame. GPU dumps are made from real frame bundles (rtoracle render) by frame_mutate,
# which copies the files a harness writes and injects one fault, printing where; each fault must be caught and named
# with its stage, bounce and element. Controls: the unmodified copy, shuffled queues (multisets), the accepted
# alternative layouts and an accum change within tolerance pass; conflicts and drops (the flood plugin) are reported
# as not comparable. Bad input (a tampered bundle, a mistyped or unreadable dump file, nothing to compare) exits 2
# with one line.
set -u
RTO=$1
MUT=$2
FLOOD=$3
EDIT=$4
FIX=$5
. "$(dirname "$0")/cli_lib.sh"

# fresh GPU dump: dump BUNDLE MUTATION [D] -> $T/g, prints what frame_mutate printed. Only the dumps that test the
# image keep image.png: reading a PNG loads OpenImageIO (about half a second a run)
dump() {
    rm -rf "$T/g"
    "$MUT" "$2" "$1" "$T/g" ${3:+"$3"} || fail "frame_mutate $*"
    case $2 in
    copy | image-* | not-comparable) ;;
    *) rm -f "$T/g/image.png" ;;
    esac
}
# word KEY : the value of KEY=VALUE in frame_mutate's output ($w)
word() { printf '%s\n' "$w" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
# fails MUTATION D FAULT : the dump is refused with FAULT at bounce D (JSON and text; text only in the optimised
# build), and writes a report unless --no-artifacts
fails() {
    w=$(dump "$B" "$1" ${2#-})
    run 1 "$RTO" check-frame --expected "$B" --gpu "$T/g" --json --no-artifacts || return
    has "\"fault\": \"$3\"" out
    [ "$2" = - ] || loc bounce "$2"
    [ -z "$(word ray)" ] || loc ray "$(word ray)"
    [ -z "$(word pixel)" ] || loc pixel "$(word pixel)"
    [ -z "$(word x)" ] || { loc x "$(word x)" && loc y "$(word y)"; }
    [ -f "$T/g/check-frame.json" ] && fail "--no-artifacts wrote a report ($1)"
    # the text report and the artefacts once more in the optimised build (under the sanitizers each run costs
    # seconds; the JSON run above went through the same checks)
    [ -z "${RTO_TEST_SANITIZED:-}" ] || return 0
    run 1 "$RTO" check-frame --expected "$B" --gpu "$T/g" && has "^FAIL $3: " out
    [ "$2" = - ] || has "^  where        bounce $2" out
    [ -f "$T/g/check-frame.json" ] || fail "no report written for $1"
}

run 0 "$RTO" check-frame --help && has usage out && has "emit-count, indirect-args, queue" out
run 0 "$RTO" --help && has check-frame out

# sun-shadow on rtstress:2: a primary queue, a shadow queue with rays (the shadow bounce is traced), a last queue
run 0 "$RTO" render rtstress:2 --program sun-shadow --width 32 --height 24 --stages all -o "$T/e"
n1=$(sed -n 's/.* \([0-9]*\) emitted.*/\1/p' "$T/out")
[ "${n1:-0}" -gt 768 ] || fail "the shadow queue of rtstress:2 should hold rays (emitted $n1)"

# controls: the copy, shuffled queues, the accepted layouts, accum as EXR, a change within tolerance
w=$(dump "$T/e" copy)
run 0 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" && has "^PASS ok: " out &&
    has "^check-frame sun-shadow 32x24 rtstress:2: maxDepth 2" out
rm "$T/g/image.png"
run 0 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --json && has '"result": "pass"' out &&
    has '"queues": true' out && has '"hits": true' out && has '"accum": true' out
for m in "shuffle 0" "shuffle 1" words full store accum-exr accum-small "payload-small 1"; do
    w=$(dump "$T/e" $m)
    run 0 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" || fail "control $m"
done
[ -z "$(ls "$T/g" | grep check-frame)" ] || fail "a passing check wrote artefacts"

# the lean golden (render's default) of the same frame: no per-bounce buffer and no accum.exr; a full GPU dump passes
# on what it keeps (counters, indirect args, accum, image), the queues and hits it does not keep named as such, and a
# fault in what it keeps still fails
run 0 "$RTO" render rtstress:2 --program sun-shadow --width 32 --height 24 -o "$T/lean"
for f in bounce_0_rays.npy bounce_0_hits.npy bounce_1_payloads.npy accum.exr; do
    [ -e "$T/lean/$f" ] && fail "the lean golden holds $f"
done
[ -f "$T/lean/accum.npy" ] && [ -f "$T/lean/image.png" ] && [ -f "$T/lean/frame_counters.npy" ] ||
    fail "the lean golden lacks accum.npy, image.png or frame_counters.npy"
w=$(dump "$T/e" copy)
run 0 "$RTO" check-frame --expected "$T/lean" --gpu "$T/g" && has "^PASS ok: " out && has "not kept by the bundle" out
B=$T/lean fails accum-big - accum
B=$T/lean fails emit 1 emit-count

# the committed frame goldens, as a harness loads them (their own buffers pass; the image is left out for speed);
# every 4th under the sanitizer
k=0
for f in "$FIX"/golden/frame-*; do
    k=$((k + 1))
    [ $(((k - 1) % $(sampled 4))) = 0 ] || continue
    w=$(dump "$f" words)
    run 0 "$RTO" check-frame --expected "$f" --gpu "$T/g" || fail "golden $f"
done

# a partial dump: what is absent is "not dumped", not failed
w=$(dump "$T/e" copy)
rm "$T/g/bounce_1_hits.npy" "$T/g/accum.npy" "$T/g/indirect_args.npy"
run 0 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" &&
    has "not dumped: indirect_args.npy, bounce_1_hits.npy, accum" out
run 0 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --json && has '"not_dumped": 3' out &&
    has '"indirect": null' out

# the mutations, each named at the stage, bounce and element where it was made
B=$T/e
fails missing 1 queue && has "ray $(word ray) of the oracle's queue .* is missing" out
fails duplicate 1 queue && has "appears 2 times in the GPU's queue, 1 in the oracle's" out
fails missing 0 queue
fails duplicate 0 queue
fails ray-dir 0 queue && has "differs: dir.x" out
fails payload 1 payload
fails prim 0 hits && has "prim: ray $(word ray)" out
# the record faults of the fault corpus (tests/test_conformance.c plants them in simulated GPUs for check-hits):
# each named at its bounce with its class and ray
# (all five in the optimised build; one under the sanitizers, where each check-frame costs seconds)
muts="hit-uv:bary hit-custom:custom-index hit-group:hit-group hit-transform:transform hit-tmin:t"
[ -n "${RTO_TEST_SANITIZED:-}" ] && muts="hit-tmin:t"
for m in $muts; do
    fails "${m%%:*}" 0 hits && has "${m#*:}: ray $(word ray)" out
done
fails emit 0 emit-count
fails emit 1 emit-count && has "emit_counts 101" out
fails indirect 1 indirect-args && has "\[3, 1, 1\] in the GPU's dump, the oracle's \[2, 1, 1\]" out
fails accum-big - accum
if [ -f "$T/e/image.png" ]; then
    fails image-shift - image
    [ -n "${RTO_TEST_SANITIZED:-}" ] ||
        { [ -f "$T/g/check-frame.image_diff.png" ] && [ -f "$T/g/check-frame.diffs.json" ]; } ||
        fail "no image diff artefacts"
    # +-1 everywhere passes, and 0.1 % of 768 pixels is 0.768: one pixel off by 2 fails; with 0.5 % (3.84) three
    # pass and four fail
    w=$(dump "$T/e" image-pixels 1)
    run 1 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --no-artifacts &&
        has "^FAIL image: 1 of 768 compared pixels" out && has "where        pixel $(word pixel), x $(word x)" out
    w=$(dump "$T/e" image-pixels 3)
    run 0 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --image-fail-percent 0.5 &&
        has "3 image pixel(s) beyond +-1, within the 0.5 % allowed" out
    w=$(dump "$T/e" image-pixels 4)
    run 1 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --image-fail-percent 0.5 --json --no-artifacts &&
        has '"fault": "image"' out && has '"image_over": 4' out && loc pixel "$(word pixel)"
else
    fail "the frame bundle has no image.png"
fi
# A dump image whose header claims 16384 x 16384 (gigabytes decoded, its pixel data a stub) is named as the wrong
# size from its header, within a second and 300 MB: image.png as 8-bit RGBA, accum.exr as float RGBA.
w=$(dump "$T/e" copy)
python3 "$(dirname "$0")/big_image.py" "$T/g/image.png" 16384 16384
bounded 1 "check-frame, image.png of 16384 x 16384" "$RTO" check-frame --expected "$T/e" --gpu "$T/g" \
    --no-artifacts && has "^FAIL image: image.png is 16384 x 16384; the frame is 32 x 24" out
w=$(dump "$T/e" copy)
rm "$T/g/accum.npy"
python3 "$(dirname "$0")/big_image.py" "$T/g/accum.exr" 16384 16384
bounded 1 "check-frame, accum.exr of 16384 x 16384" "$RTO" check-frame --expected "$T/e" --gpu "$T/g" \
    --no-artifacts && has "^FAIL accum: accum.exr is 16384 x 16384; the frame is 32 x 24" out

# the accum diff artefacts, and --artifacts DIR
w=$(dump "$T/e" accum-big)
run 1 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" && has "diff listing written" err
[ -f "$T/g/check-frame.accum_diff.exr" ] && [ -f "$T/g/check-frame.diffs.json" ] || fail "no accum diff artefacts"
grep -q "\"x\": $(word x)" "$T/g/check-frame.diffs.json" || fail "the listing does not name pixel $(word pixel)"
mkdir "$T/art"
run 1 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --artifacts "$T/art"
[ -f "$T/art/check-frame.json" ] && [ -f "$T/art/check-frame.accum_diff.exr" ] || fail "--artifacts DIR unused"
# --artifacts naming a bundle, or a directory inside one, is refused (a bundle holds only what its manifest lists,
# and a later render -o would refuse to replace it); the bundle is left as it was.
mkdir -p "$T/e/inner"
for a in "$T/e" "$T/e/inner"; do
    run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --artifacts "$a" && has "refusing to write $a" err
    [ -e "$a/check-frame.json" ] && fail "--artifacts $a wrote into the bundle"
done
rmdir "$T/e/inner"

# the first divergence in pipeline order is the primary fault; later ones are listed
w=$(dump "$T/e" missing 1)
"$MUT" accum-big "$T/e" "$T/g2" >/dev/null && cp "$T/g2/accum.npy" "$T/g/accum.npy"
run 1 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --json --no-artifacts && has '"fault": "queue"' out &&
    has '"accum"' out && has "later: accum" out

# the stage2 scene (seed 002's analytic primitives): hits compare without re-intersection
run 0 "$RTO" render stage2 --program normals --width 16 --height 12 --stages all -o "$T/s2"
w=$(dump "$T/s2" copy)
rm "$T/g/image.png"
run 0 "$RTO" check-frame --expected "$T/s2" --gpu "$T/g" && has "^check-frame normals 16x12 stage2" out
B=$T/s2
fails prim 0 hits && has "hits: bounce 0 (stage2 scene.*: prim: ray $(word ray)" out
fails missing 0 queue
B=$T/e

# conflicts (the flood plugin, emit = 0): those pixels are left out; a change elsewhere still fails
run 0 "$RTO" render rtstress:2 --program "$FLOOD" --param emit=0 --width 16 --height 12 --stages all -o "$T/f0"
w=$(dump "$T/f0" not-comparable)
[ "$(word pixels)" = 48 ] || fail "flood should mark 48 conflict pixels, not $(word pixels)"
run 0 "$RTO" check-frame --expected "$T/f0" --gpu "$T/g" && has "not comparable: 48 pixel(s) .*48 conflict" out
w=$(dump "$T/f0" accum-big)
run 1 "$RTO" check-frame --expected "$T/f0" --gpu "$T/g" --no-artifacts && has "^FAIL accum" out
# drops (emit = 2): the dropping queue and those after it compare by their counts only
run 0 "$RTO" render rtstress:2 --program "$FLOOD" --width 16 --height 12 --stages all -o "$T/f2"
has " 96 dropped" out
w=$(dump "$T/f2" not-comparable)
[ "$(word queue)" = 1 ] || fail "flood should drop rays in queue 1"
run 0 "$RTO" check-frame --expected "$T/f2" --gpu "$T/g" && has "queue 1 dropped 96 ray(s): it and later queues" out &&
    has "not comparable: 192 pixel(s)" out
w=$(dump "$T/f2" emit 1)
run 1 "$RTO" check-frame --expected "$T/f2" --gpu "$T/g" --json --no-artifacts && has '"fault": "emit-count"' out &&
    loc bounce 1

# bad usage and dumps: status 2, one line
one_line() { [ "$(wc -l <"$T/err")" = 1 ] || fail "stderr is not one line: $(cat "$T/err")"; }
w=$(dump "$T/e" copy)
run 2 "$RTO" check-frame --gpu "$T/g" && has "required" err
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/none" && has "none" err && one_line
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g/emit_counts.npy" && has "not a directory" err
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" --image-fail-percent 101 && has "image-fail-percent" err
mkdir "$T/empty"
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/empty" && has "nothing to compare" err && one_line
run 0 "$RTO" trace rtstress:2 --rays primary --width 8 --height 8 -o "$T/tr"
run 2 "$RTO" check-frame --expected "$T/tr" --gpu "$T/g" && has "not a frame bundle" err
cp "$T/g/accum.npy" "$T/g/emit_counts.npy"
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" && has "emit_counts.npy: holds dtype <f4" err && one_line
w=$(dump "$T/e" copy)
head -c 100 "$T/e/bounce_0_rays.npy" >"$T/g/bounce_0_rays.npy"
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" && has "bounce_0_rays.npy" err && one_line
w=$(dump "$T/e" copy)
cp "$T/e/bounce_0_hits.npy" "$T/g/bounce_0_rays.npy"
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" && has "WfRay" err
w=$(dump "$T/e" copy)
rm "$T/g/bounce_1_rays.npy" && mkfifo "$T/g/bounce_1_rays.npy"
run 2 "$RTO" check-frame --expected "$T/e" --gpu "$T/g" && has "not a regular file" err && one_line

# tampered bundles: bundle_edit rewrites the manifest's sha256, so only the checks of the arrays can refuse them
w=$(dump "$T/e" copy)
edited() {
    local file=$1
    shift
    rm -rf "$T/x" && cp -r "$T/e" "$T/x" && "$EDIT" "$T/x/$file" "$@" >/dev/null || fail "bundle_edit $file $*"
}
refused() {
    run 2 "$RTO" check-frame --expected "$T/x" --gpu "$T/g" || return
    one_line
    has "$1" err
}
edited emit_counts.npy truncate 3 # control: an unedited copy passes
run 0 "$RTO" check-frame --expected "$T/x" --gpu "$T/g"
printf x >>"$T/x/emit_counts.npy"
refused "sha256"
edited emit_counts.npy truncate 3
rm "$T/x/indirect_args.npy"
refused "indirect_args.npy"
edited emit_counts.npy truncate 2
refused "emit_counts.npy: holds dtype <u4, shape (2,); expected dtype <u4, shape (3,)"
edited frame_counters.npy set-u32 0 700 # queue 0's emitted
refused "queue 0: emitted 700, but emit_counts.npy says 768"
edited indirect_args.npy set-u32 3 5
refused "queue 1: \[5, 1, 1\] is not \[ceil(100 / 64), 1, 1\]"
edited not_comparable.npy set-u32 0 0x04
refused "not_comparable.npy: pixel 0 holds 0x04"
edited not_comparable.npy as-u32
refused "not_comparable.npy: holds dtype <u4"
edited bounce_1_rays.npy truncate 99
refused "bounce_1_rays.npy: holds 64-byte records, shape (99,); expected 64-byte records, shape (100,)"
w=$(dump "$T/e" prim 0)
edited bounce_0_hits.npy set-f32 $(($(word ray) * 24)) 1000
refused "bounce_0_hits.npy: expected record $(word ray) is not the hit record of triangle"
# the scene is read (a GPU hit on another primitive is re-intersected with it) by the one reader check-hits uses too
. "$(dirname "$0")/scene_bundle_cases.sh"
scene_bundle_cases
finish "cli.check_frame: ok"

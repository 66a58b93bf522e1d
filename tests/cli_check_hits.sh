#!/usr/bin/env bash
# Command-line tests of check-hits: a trace bundle's own hits pass in every dump shape; each mutation of a hit record
# is named with its fault class at the ray where it was made (hits_mutate prints it); first-hit (shadow) rays; a
# tampered bundle (a file deleted, a wrong dtype, an index past its mesh, an expected record that is not its
# primitive's hit) is refused with status 2 and one line.
set -u
RTO=$1
MUT=$2
FIX=$3
EDIT=$4
. "$(dirname "$0")/cli_lib.sh"

run 0 "$RTO" check-hits --help && has usage out && has "custom-index, hit-group" out
run 0 "$RTO" --help && has check-hits out

run 0 "$RTO" trace rtstress:2 --rays primary --width 64 --height 48 -o "$T/rs"
run 0 "$RTO" check-hits --expected "$T/rs" --gpu "$T/rs/hits.npy" && has "^PASS ok: 3072 rays" out &&
    has "^check-hits primary rays 64x48: 3072 rays" out
run 0 "$RTO" check-hits --expected "$T/rs" --gpu "$T/rs/hits.npy" --json && has '"result": "pass"' out &&
    has '"ties": 0' out
# the same records as (n, 24) float32 words and as the flat uint32 buffer
for f in words flat; do
    "$MUT" $f "$T/rs/hits.npy" "$T/g.npy" || fail "hits_mutate $f"
    run 0 "$RTO" check-hits --expected "$T/rs" --gpu "$T/g.npy"
done
# the committed trace goldens, as a harness loads them
for g in "$FIX"/golden/trace-*; do
    run 0 "$RTO" check-hits --expected "$g" --gpu "$g/hits.npy" || fail "golden $g"
done
run 0 "$RTO" trace "$FIX/Box/glTF/Box.gltf" --rays primary --width 64 --height 48 -o "$T/box"
run 0 "$RTO" check-hits --expected "$T/box" --gpu "$T/box/hits.npy"

# every mutation, named at its ray (JSON location and text alike); the report goes next to the dump
for m in t:t bary-swap:bary hit-to-miss:miss-flag miss-to-hit:miss-flag flag-2:miss-flag prim:prim \
    instance:instance oob-instance:instance custom-index:custom-index hit-group:hit-group row-major:transform \
    truncate:size; do
    ray=$("$MUT" "${m%%:*}" "$T/rs/hits.npy" "$T/g.npy") || { fail "hits_mutate ${m%%:*}"; continue; }
    run 1 "$RTO" check-hits --expected "$T/rs" --gpu "$T/g.npy" --json --no-artifacts &&
        has "\"fault\": \"${m#*:}\"" out && loc ray "$ray"
    [ -f "$T/g.npy.check-hits.json" ] && fail "--no-artifacts wrote a report (${m%%:*})"
    run 1 "$RTO" check-hits --expected "$T/rs" --gpu "$T/g.npy" && has "^FAIL ${m#*:}: .*ray $ray" out &&
        has "^  where        ray $ray\$" out
    [ -f "$T/g.npy.check-hits.json" ] || fail "no report artefact for ${m%%:*}"
    rm -f "$T/g.npy.check-hits.json"
done

# shadow rays: TERMINATE_ON_FIRST_HIT, so only hit / miss and the claimed hit itself are compared
run 0 "$RTO" trace rtstress:2 --rays shadow --width 32 --height 24 -o "$T/sh"
run 0 "$RTO" check-hits --expected "$T/sh" --gpu "$T/sh/hits.npy" && has "^PASS" out
if grep -q '"misses": [1-9]' "$T/sh/manifest.json" && grep -q '"hits": [1-9]' "$T/sh/manifest.json"; then
    for m in t:t hit-to-miss:miss-flag miss-to-hit:miss-flag oob-instance:instance; do
        ray=$("$MUT" "${m%%:*}" "$T/sh/hits.npy" "$T/g.npy") || { fail "hits_mutate ${m%%:*} (shadow)"; continue; }
        run 1 "$RTO" check-hits --expected "$T/sh" --gpu "$T/g.npy" --json --no-artifacts &&
            has "\"fault\": \"${m#*:}\"" out && loc ray "$ray"
    done
    # another customIndex is not compared for a first-hit ray
    "$MUT" custom-index "$T/sh/hits.npy" "$T/g.npy" >/dev/null
    run 0 "$RTO" check-hits --expected "$T/sh" --gpu "$T/g.npy"
else
    fail "the shadow rays of rtstress:2 should both hit and miss"
fi

# bad usage and dumps: status 2, one line
run 2 "$RTO" check-hits --expected "$T/rs" && has "required" err
run 2 "$RTO" check-hits --expected "$T/rs" --gpu "$T/rs/rays.npy" && has "HitRecord" err
run 2 "$RTO" check-hits --expected "$T/rs" --gpu "$T/nothing.npy" && has "nothing.npy" err
run 2 "$RTO" check-hits --expected "$T/none" --gpu "$T/rs/hits.npy" && has "none" err
run 0 "$RTO" build rtstress:2 -o "$T/build"
run 2 "$RTO" check-hits --expected "$T/build" --gpu "$T/rs/hits.npy" && has "not a trace bundle" err

# tampered bundles: each edit rewrites the manifest's sha256, so only the checks of the arrays can refuse it
edited() {
    local file=$1
    shift
    rm -rf "$T/e" && cp -r "$T/rs" "$T/e" && "$EDIT" "$T/e/$file" "$@" >/dev/null || fail "bundle_edit $file $*"
}
refused() {
    run 2 "$RTO" check-hits --expected "$T/e" --gpu "$T/rs/hits.npy" || return
    [ "$(wc -l <"$T/err")" = 1 ] || fail "stderr is not one line: $(cat "$T/err")"
    has "$1" err
}
edited hits.npy truncate 3072 # control: an unedited copy passes
run 0 "$RTO" check-hits --expected "$T/e" --gpu "$T/rs/hits.npy"
rm -f "$T/e/mesh_0_indices.npy"
refused "mesh_0_indices.npy"
. "$(dirname "$0")/scene_bundle_cases.sh"
scene_bundle_cases # the scene's cases, shared with check-frame (one reader)
edited rays.npy truncate 100
refused "rays.npy: holds WfRay records, shape (100,); expected WfRay records, shape (3072,)"
edited rays.npy set-f32 4 nan # ray 0's direction x
refused "rays.npy: ray 0 has a non-finite"
edited hits.npy truncate 3071
refused "hits.npy: holds HitRecord records, shape (3071,)"
# an expected hit whose t is not its primitive's: the first hit record at or after the middle, t word
ray=$("$MUT" t "$T/rs/hits.npy" "$T/g.npy")
edited hits.npy set-f32 $((ray * 24)) 1000
refused "hits.npy: expected record $ray is not the hit record of triangle"
edited hits.npy set-u32 $((ray * 24 + 7)) 1 # a hit turned into a bad miss: the manifest's counts disagree
refused "hits.npy: [0-9]* hits and [0-9]* misses; the manifest says trace.hits"
finish "cli.check_hits: ok"

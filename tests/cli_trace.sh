#!/usr/bin/env bash
# Command-line tests of trace: every ray set on a fixture and a procedural scene, the bundle's files and manifest,
# bytes independent of --threads and of the run, a ray file traced to the same hits, and refusals (exit 2, one line,
# nothing written) of bad options, bad ray files and outputs that are not ours.
set -u
RTO=$1
FIX=$2
EDIT=$3
JSON=$4
. "$(dirname "$0")/cli_lib.sh"

run 0 "$RTO" trace --help && has usage out && has "hits.npy" out
box="$FIX/Box/glTF/Box.gltf"

field() { "$JSON" "$1/manifest.json" "$2"; }

for scene in "$box" rtstress:2; do
    tag=$(basename "$scene" | tr -c 'a-zA-Z0-9\n' _)
    for set in primary shadow random grazing axis; do
        out="$T/${tag}_$set"
        run 0 "$RTO" trace "$scene" --rays $set --width 64 --height 48 --count 2000 -o "$out" || continue
        [ "$(field "$out" kind)" = '"trace"' ] || fail "$tag $set: kind $(field "$out" kind)"
        [ "$(field "$out" trace/rays)" = "\"$set\"" ] || fail "$tag $set: trace.rays"
        n=$(field "$out" trace/count)
        case $set in
        primary) [ "$n" = 3072 ] || fail "$tag primary: $n rays, want 64 x 48" ;;
        shadow) [ "$n" -le "$(field "$T/${tag}_primary" trace/hits)" ] || fail "$tag shadow: more rays than hits" ;;
        *) [ "$n" -le 2000 ] || fail "$tag $set: $n rays" ;;
        esac
        h=$(field "$out" trace/hits)
        m=$(field "$out" trace/misses)
        [ $((h + m)) = "$n" ] || fail "$tag $set: hits $h + misses $m != $n"
        for f in rays.npy hits.npy counters.npy mesh_0_positions.npy mesh_0_indices.npy tlas_nodes.npy \
            instances.npy; do
            [ -f "$out/$f" ] || fail "$tag $set: no $f"
        done
        case $set in primary | shadow) [ -f "$out/camera.npy" ] || fail "$tag $set: no camera.npy" ;; esac
        field "$out" counters/nodes_visited_mean >/dev/null || fail "$tag $set: no counter statistics"
        field "$out" histogram_box_tests >/dev/null || fail "$tag $set: no box-test histogram"
        # one 96-byte record per ray
        [ "$(stat -c %s "$out/hits.npy")" -ge $((n * 96)) ] || fail "$tag $set: hits.npy too small"
    done
done
# some primary rays of the Box hit and some miss
[ "$(field "$T/Box_gltf_primary" trace/hits)" -gt 100 ] || fail "Box primary: too few hits"
[ "$(field "$T/Box_gltf_primary" trace/misses)" -gt 100 ] || fail "Box primary: too few misses"

# bytes independent of the thread count, the run and the TLAS layout's effect on hits
run 0 "$RTO" trace rtstress:3 --rays random --count 5000 --threads 1 -o "$T/t1"
run 0 "$RTO" trace rtstress:3 --rays random --count 5000 --threads 2 -o "$T/t2"
run 0 "$RTO" trace rtstress:3 --rays random --count 5000 --threads 7 -o "$T/t7"
diff -r "$T/t1" "$T/t2" >/dev/null || fail "--threads 1 and 2 differ"
diff -r "$T/t1" "$T/t7" >/dev/null || fail "--threads 1 and 7 differ"
run 0 "$RTO" trace rtstress:3 --rays random --count 5000 --seed 2 -o "$T/s2"
cmp -s "$T/t1/rays.npy" "$T/s2/rays.npy" && fail "another seed gave the same rays"

# a ray file is traced to the same hits; the manifest names the file
run 0 "$RTO" trace rtstress:3 --rays "$T/t1/rays.npy" -o "$T/f"
cmp -s "$T/t1/hits.npy" "$T/f/hits.npy" || fail "the ray file gave other hits"
cmp -s "$T/t1/counters.npy" "$T/f/counters.npy" || fail "the ray file gave other counters"
[ -f "$T/f/camera.npy" ] && fail "a ray file has no camera"
# the same rays as flat float32 words
cp "$T/t1/rays.npy" "$T/flat.npy"
"$EDIT" "$T/flat.npy" as-u32 >/dev/null
run 0 "$RTO" trace rtstress:3 --rays "$T/flat.npy" -o "$T/ff"
cmp -s "$T/t1/hits.npy" "$T/ff/hits.npy" || fail "flat ray words gave other hits"

# cameras: the scene's, automatic, an index, explicit
run 0 "$RTO" trace "$box" --camera auto --width 32 --height 24 -o "$T/ca"
[ "$(field "$T/ca" camera/name)" = '"auto"' ] || fail "--camera auto: camera.name"
run 0 "$RTO" trace rtstress:2 --camera 0 --width 32 --height 24 -o "$T/c0"
run 0 "$RTO" trace triangle --camera 0,0,3,0,0,0,0,1,0,60 --width 33 --height 33 -o "$T/ce"
[ "$(field "$T/ce" trace/hits)" -gt 0 ] || fail "explicit camera: no hit"

# refusals: one line on stderr, exit 2, nothing written
bad() {
    local what=$1
    shift
    rm -rf "$T/bad"
    run 2 "$RTO" trace "$@" -o "$T/bad" || return
    [ "$(wc -l <"$T/err")" = 1 ] || fail "$what: not one line: $(cat "$T/err")"
    grep -q "^rtoracle trace: " "$T/err" || fail "$what: message not prefixed"
    [ -e "$T/bad" ] && fail "$what: output written"
    ls "$T" | grep -q '^bad\.tmp' && fail "$what: a temporary was left"
}
bad "unknown set" triangle --rays sideways
bad "width 0" triangle --width 0
bad "too many pixels" triangle --width 65536 --height 65536
bad "camera index" triangle --camera 3
bad "camera text" triangle --camera 1,2,3
bad "camera nan" triangle --camera 0,0,3,0,0,0,0,1,0,nan
bad "degenerate camera" triangle --camera 0,0,3,0,0,3,0,1,0,60
bad "light" triangle --rays shadow --light 1,2
bad "missing ray file" triangle --rays "$T/none.npy"
bad "missing scene" "$T/none.gltf"
mkfifo "$T/fifo.npy"
bad "FIFO ray file" triangle --rays "$T/fifo.npy"
has "regular" err
cp "$T/t1/rays.npy" "$T/nan.npy"
"$EDIT" "$T/nan.npy" set-f32 17 nan >/dev/null # ray 1's origin.y
bad "NaN ray" rtstress:3 --rays "$T/nan.npy"
has "^rtoracle trace: $T/nan.npy: ray 1 has a non-finite" err
cp "$T/t1/rays.npy" "$T/short.npy"
truncate -s -10 "$T/short.npy"
bad "truncated ray file" rtstress:3 --rays "$T/short.npy"
cp "$T/t1/hits.npy" "$T/wrong.npy"
bad "hit records as rays" rtstress:3 --rays "$T/wrong.npy"
# a user's file or a directory that is not a bundle is never replaced
echo keep >"$T/user.txt"
run 2 "$RTO" trace triangle -o "$T/user.txt"
[ "$(cat "$T/user.txt")" = keep ] || fail "a user's file was replaced"
mkdir "$T/userdir" && echo keep >"$T/userdir/notes"
run 2 "$RTO" trace triangle -o "$T/userdir"
[ -f "$T/userdir/notes" ] || fail "a user's directory was replaced"
# a previous trace bundle is replaced
run 0 "$RTO" trace triangle -o "$T/t1"

finish "trace: every ray set, thread-independent bytes, ray files and refusals as expected"

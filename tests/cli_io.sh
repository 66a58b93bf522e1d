#!/usr/bin/env bash
# Command-line tests of output safety: what -o may replace (bundles of ours only, links followed, nothing else
# touched), reports and .npy files written atomically and never over anything but a regular file, no *.tmp.* left
# by SIGINT / SIGTERM, permissions from the umask, and JSON that is valid whatever the names and numbers.
set -u
RTO=$1
JSON=$2 # tests/tools/json_get: strict JSON check (jansson) and value lookup
. "$(dirname "$0")/cli_lib.sh"

# refused CMD... : exit 2, exactly one line on stderr
refused() {
    run 2 "$@" || return 1
    [ "$(wc -l <"$T/err")" = 1 ] || { fail "want exactly one stderr line: $*"; sed 's/^/    | /' "$T/err"; }
    return 0
}
no_temporaries() {
    local left
    left=$(find "$T" -name '*.tmp.*' | head -5)
    [ -z "$left" ] || fail "temporaries left behind ($1): $left"
}
FFFD=$'\xef\xbf\xbd'

# ---- -o DIR: the directory of the issue (an empty manifest.json and a user's index.html) is not a bundle
mkdir "$T/w" && echo '{}' >"$T/w/manifest.json" && echo x >"$T/w/index.html"
refused "$RTO" build triangle -o "$T/w" && has "not an rtoracle bundle" err
[ "$(cat "$T/w/index.html" 2>/dev/null)" = x ] || fail "build -o removed a user's index.html"
[ "$(cat "$T/w/manifest.json")" = '{}' ] || fail "build -o changed a foreign manifest.json"
# a manifest of another format version, or with no files list, is not ours to replace either
printf '{"format": "rtoracle-bundle", "format_version": 2, "files": []}' >"$T/w/manifest.json"
refused "$RTO" build triangle -o "$T/w" && has "format_version" err
printf '{"format": "rtoracle-bundle", "format_version": 1}' >"$T/w/manifest.json"
refused "$RTO" build triangle -o "$T/w" && has '"files"' err
printf '{"format": "rtoracle-bundle", "format_version": 1, "files": [{"name": "../x"}]}' >"$T/w/manifest.json"
refused "$RTO" build triangle -o "$T/w" && has "plain name" err
[ -f "$T/w/index.html" ] || fail "a refused build removed index.html"
echo '{}' >"$T/w/manifest.json"

# control: a bundle of ours is replaced, also through a second run, and an empty directory is taken
run 0 "$RTO" build triangle -o "$T/b"
run 0 "$RTO" build rtstress:2 -o "$T/b" && grep -q rtstress "$T/b/manifest.json" || fail "a bundle was not replaced"
mkdir "$T/empty" && run 0 "$RTO" build triangle -o "$T/empty" && [ -f "$T/empty/manifest.json" ] ||
    fail "an empty directory was not taken"
# a real bundle with one file of the user's in it is the user's: refused, every byte kept
cp -r "$T/b" "$T/b_copy" && echo notes >"$T/b/notes.txt"
refused "$RTO" build triangle -o "$T/b" && has "notes.txt" err
rm "$T/b/notes.txt" && diff -r "$T/b" "$T/b_copy" >/dev/null || fail "a refused build changed the bundle"
# a listed file that is not a regular file (here a directory) is not the bundle's
f=$(ls "$T/b" | grep npy | head -1)
mv "$T/b/$f" "$T/f.npy" && mkdir "$T/b/$f"
refused "$RTO" build triangle -o "$T/b" && has "not a regular file" err
rmdir "$T/b/$f" && mv "$T/f.npy" "$T/b/$f"

# suites: cases are subdirectories listed in the manifest, each a bundle itself
run 0 "$RTO" suite sort --sizes 17,64 --dists uniform --formats u32 -o "$T/s"
run 0 "$RTO" suite sort --sizes 17,64 --dists uniform --formats u32 -o "$T/s" # replaced whole
case1=$(ls "$T/s" | grep -v manifest | head -1)
echo mine >"$T/s/$case1/mine.txt"
refused "$RTO" suite sort --sizes 17 --dists uniform --formats u32 -o "$T/s" && has "$case1/mine.txt" err
[ -f "$T/s/$case1/mine.txt" ] && [ -f "$T/s/$case1/manifest.json" ] || fail "a refused suite touched a case"
rm "$T/s/$case1/mine.txt" && mkdir "$T/s/extra"
refused "$RTO" suite sort --sizes 17 --dists uniform --formats u32 -o "$T/s" && has "extra" err
rmdir "$T/s/extra"
run 0 "$RTO" suite sort --sizes 17 --dists uniform --formats u32 -o "$T/s"
[ "$(ls "$T/s" | wc -l)" = 3 ] || fail "a replaced suite kept old cases: $(ls "$T/s")" # 2 algos + manifest

# -o naming a symbolic link: followed (the bundle it names is replaced, the link stays); anything else refused
ln -s b "$T/link"
run 0 "$RTO" build triangle -o "$T/link"
[ -L "$T/link" ] && [ "$(readlink "$T/link")" = b ] || fail "build -o LINK replaced the link"
grep -q '"scene": "triangle"' "$T/b/manifest.json" || fail "build -o LINK did not replace the bundle it names"
ln -s w "$T/wlink"
refused "$RTO" build triangle -o "$T/wlink" && has "not an rtoracle bundle" err
[ -L "$T/wlink" ] && [ -f "$T/w/index.html" ] || fail "a refused build through a link touched something"
ln -s missing "$T/dangling"
refused "$RTO" build triangle -o "$T/dangling" && has "symbolic link" err
[ -L "$T/dangling" ] && [ ! -e "$T/missing" ] || fail "build -o DANGLING changed the link or created its target"
# a regular file, a missing parent directory, a parent that is a file
echo data >"$T/plain"
refused "$RTO" build triangle -o "$T/plain" && has "not a directory" err
[ "$(cat "$T/plain")" = data ] || fail "build -o FILE changed the file"
refused "$RTO" build triangle -o "$T/nodir/out" && has "nodir" err
run 0 "$RTO" keys --dist uniform --n 100 -o "$T/k.npy"
refused "$RTO" sort "$T/k.npy" -o "$T/plain/out"
[ -e "$T/nodir" ] && fail "a refused build created the missing parent"
no_temporaries "-o refusals"

# ---- reports and .npy files: atomic, and only over a regular file (a link is followed)
run 1 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/k.npy" # unsorted: a mismatch, with a report
[ -f "$T/k.npy.check-sort.json" ] && "$JSON" "$T/k.npy.check-sort.json" fault >/dev/null ||
    fail "no valid report next to the dump"
rm "$T/k.npy.check-sort.json" && mkdir "$T/k.npy.check-sort.json"
refused "$RTO" check-sort --input "$T/k.npy" --gpu "$T/k.npy" && has "directory" err
[ -d "$T/k.npy.check-sort.json" ] || fail "the report replaced a directory"
rmdir "$T/k.npy.check-sort.json" && mkfifo "$T/k.npy.check-sort.json"
timeout 20 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/k.npy" >"$T/out" 2>"$T/err"
[ $? = 2 ] && grep -q "not a regular file" "$T/err" || fail "a report over a FIFO: exit $?, $(cat "$T/err")"
[ -p "$T/k.npy.check-sort.json" ] || fail "the report replaced a FIFO"
rm "$T/k.npy.check-sort.json" && echo old >"$T/report_target" && ln -s report_target "$T/k.npy.check-sort.json"
run 1 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/k.npy"
[ -L "$T/k.npy.check-sort.json" ] && "$JSON" "$T/report_target" fault >/dev/null ||
    fail "a report through a link replaced the link or not its target"
rm "$T/k.npy.check-sort.json"
ln -s k.npy "$T/klink.npy"
run 0 "$RTO" keys --dist clustered --n 50 -o "$T/klink.npy"
[ -L "$T/klink.npy" ] && cmp -s "$T/klink.npy" "$T/k.npy" || fail "keys -o LINK replaced the link"
mkdir "$T/kdir.npy"
refused "$RTO" keys --dist uniform --n 10 -o "$T/kdir.npy" && has "directory" err
run 0 "$RTO" keys --dist uniform --n 10 -o /dev/null # a device is written through, never replaced
no_temporaries "reports"

# ---- permissions follow the umask, like mkdir / open with 0777 / 0666
for um in 022 077 002; do
    (
        umask $um
        "$RTO" sort "$T/k.npy" -o "$T/perm_$um" >/dev/null &&
            "$RTO" keys --dist uniform --n 10 -o "$T/perm_$um.npy" &&
            "$RTO" check-sort --input "$T/perm_$um.npy" --gpu "$T/perm_$um.npy" >/dev/null 2>&1
    )
    d=$(printf '%o' $((0777 & ~8#$um)))
    f=$(printf '%o' $((0666 & ~8#$um)))
    [ "$(stat -c %a "$T/perm_$um")" = "$d" ] || fail "umask $um: bundle mode $(stat -c %a "$T/perm_$um"), want $d"
    [ "$(stat -c %a "$T/perm_$um/manifest.json")" = "$f" ] || fail "umask $um: manifest mode, want $f"
    [ "$(stat -c %a "$T/perm_$um/sorted.npy")" = "$f" ] || fail "umask $um: bundle file mode, want $f"
    [ "$(stat -c %a "$T/perm_$um.npy")" = "$f" ] || fail "umask $um: keys file mode, want $f"
    [ -f "$T/perm_$um.npy.check-sort.json" ] &&
        [ "$(stat -c %a "$T/perm_$um.npy.check-sort.json")" = "$f" ] || fail "umask $um: report mode, want $f"
done

# ---- SIGINT / SIGTERM: temporaries removed, target not created (or left as it was), the signal's exit status.
# Job control on, so the background jobs take SIGINT (a shell without it starts them with SIGINT ignored).
set -m
# interrupt SIG CMD... : starts CMD, waits until its temporary bundle (and, with WANT_CASE, a finished case in it)
# exists, sends SIG, and checks the exit status 128 + SIG.
interrupt() {
    local sig=$1 want=$2 pattern=$3
    shift 3
    "$@" >/dev/null 2>&1 &
    local pid=$! i
    for ((i = 0; i < 400; i++)); do
        compgen -G "$pattern" >/dev/null && break
        sleep 0.05
    done
    compgen -G "$pattern" >/dev/null || fail "never saw $pattern: $*"
    kill -s "$sig" "$pid"
    wait "$pid" 2>/dev/null # (the shell reports the killed job on stderr)
    local rc=$?
    [ "$rc" = "$want" ] || fail "after SIG$sig: exit $rc, want $want: $*"
}
big_suite=(suite sort --sizes 1048576,4194304 --dists uniform,clustered,random --formats u64 --algos bitonic)
# a suite interrupted after its first case was finished inside the temporary (nested bundles)
interrupt INT 130 "$T/sig1.tmp.*/bitonic-*" "$RTO" "${big_suite[@]}" -o "$T/sig1"
[ -e "$T/sig1" ] && fail "an interrupted suite created its output"
no_temporaries "SIGINT during suite"
interrupt TERM 143 "$T/sig2.tmp.*" "$RTO" "${big_suite[@]}" -o "$T/sig2"
[ -e "$T/sig2" ] && fail "a terminated suite created its output"
no_temporaries "SIGTERM during suite"
# over a previous bundle: the previous one stays as it was
cp -r "$T/s" "$T/s_before"
interrupt INT 130 "$T/s.tmp.*" "$RTO" "${big_suite[@]}" -o "$T/s"
diff -r "$T/s" "$T/s_before" >/dev/null || fail "an interrupted suite changed the previous one"
no_temporaries "SIGINT during a suite over a previous one"
run 0 "$RTO" keys --dist uniform --n 4194304 --format u64 -o "$T/big.npy"
interrupt TERM 143 "$T/sig3.tmp.*" "$RTO" sort "$T/big.npy" -o "$T/sig3"
[ -e "$T/sig3" ] && fail "a terminated sort created its output"
no_temporaries "SIGTERM during sort"
set +m
rm -f "$T/big.npy"

# ---- JSON: names that are not UTF-8 and non-finite numbers are encoded, never dropped
# one triangle; the mesh name is given as JSON text, the node may carry a translation
gltf() { # gltf FILE MESH_NAME_JSON [TRANSLATION_X [big]]: "big" puts the second vertex at x = 3e38
    local px=${4:-1}
    # positions (0,0,0) (px,0,0) (0,1,0) as little-endian binary32, then indices 0 1 2 (u16) and 2 bytes of padding
    local b64
    b64=$(
        {
            printf '\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00'
            if [ "$px" = 1 ]; then printf '\x00\x00\x80\x3f'; else printf '\xe6\xb1\x61\x7f'; fi # 1 or 3.0e38
            printf '\x00\x00\x00\x00\x00\x00\x00\x00'
            printf '\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00'
            printf '\x00\x00\x01\x00\x02\x00\x00\x00'
        } | base64 -w0
    )
    local tr=""
    [ -n "${3:-}" ] && tr=", \"translation\": [$3, 0, 0]"
    printf '{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0%s}],
 "meshes": [{"name": %s, "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
 "buffers": [{"byteLength": 44, "uri": "data:application/octet-stream;base64,%s"}],
 "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
 "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0],
   "max": [%s, 1, 0]}, {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]}\n' \
        "$tr" "$2" "$b64" "$([ "$px" = 1 ] && echo 1 || echo 3.0e38)" >"$1"
}
# a long name of two-byte characters: whatever the loader keeps of it, the mesh is listed with a UTF-8 name
long=$(printf 'é%.0s' {1..100})
gltf "$T/long.gltf" "\"$long\""
run 0 "$RTO" info "$T/long.gltf" --json
"$JSON" "$T/out" meshes/0/name >"$T/name" || fail "info --json of a long multibyte name: invalid or no mesh name"
grep -q "^\"éééé" "$T/name" || fail "info --json lost the long name: $(cat "$T/name")"
run 0 "$RTO" build "$T/long.gltf" -o "$T/long_b"
"$JSON" "$T/long_b/manifest.json" blas_0/mesh >/dev/null || fail "the build manifest lost the mesh name"
# a scene path that is not UTF-8: the source is kept, with U+FFFD for the bad byte
cp "$T/long.gltf" "$T/bad"$'\xff'"name.gltf"
run 0 "$RTO" info "$T/bad"$'\xff'"name.gltf" --json
"$JSON" "$T/out" source | grep -q "bad${FFFD}name.gltf" || fail "info --json: source not repaired: $(head -3 "$T/out")"
[ "$("$JSON" "$T/out" counts/meshes)" = "$("$JSON" "$T/out" meshes | grep -o '"name"' | wc -l)" ] ||
    fail "info --json dropped a mesh"
run 0 "$RTO" build "$T/bad"$'\xff'"name.gltf" -o "$T/bad_b"
"$JSON" "$T/bad_b/manifest.json" scene | grep -q "bad${FFFD}name.gltf" || fail "build manifest: scene not repaired"
# world bounds that overflow binary32: either encoded ("inf") or refused with one line, never dropped
gltf "$T/overflow.gltf" '"m"' 3.0e38 big
"$RTO" info "$T/overflow.gltf" --json >"$T/out" 2>"$T/err"
case $? in
0) "$JSON" "$T/out" bounds/max/0 | grep -q '"inf"' || fail "info --json: overflowing bounds not written as \"inf\"" ;;
2) [ "$(wc -l <"$T/err")" = 1 ] || fail "overflowing bounds: want one stderr line" ;;
*) fail "info --json of overflowing bounds: exit $?" ;;
esac
# every fixture's info --json is valid JSON and lists as many meshes, cameras and warnings as it counts
for f in triangle rtstress:2 "${RTO_FIXTURES:-fixtures}/Duck/glTF/Duck.gltf" \
    "${RTO_FIXTURES:-fixtures}/CornellBox-nvpro-glTF/cornellBox.gltf"; do
    run 0 "$RTO" info "$f" --json
    for k in meshes cameras warnings; do
        n=$("$JSON" "$T/out" "counts/$k") || { fail "info --json $f: invalid"; break; }
        [ "$k" = warnings ] && [ "$n" -gt 16 ] && n=16
        "$JSON" "$T/out" "$k/$((n - 1))" >/dev/null 2>&1 || [ "$n" = 0 ] || fail "info --json $f: fewer $k than $n"
        "$JSON" "$T/out" "$k/$n" >/dev/null 2>&1 && fail "info --json $f: more $k than $n"
    done
done
# ---- inputs that are not plain files: a FIFO (open() would wait for a writer), /dev/zero (never ends) given as a
# dump or the keys, or standing in for a bundle's manifest or array, is refused at once (timeout turns a hang into a
# failure) with one line, exit 2
mkfifo "$T/in_fifo"
run 0 "$RTO" keys --dist uniform --n 40 -o "$T/in_k.npy" && run 0 "$RTO" sort "$T/in_k.npy" -o "$T/in_sb"
run 0 "$RTO" build triangle -o "$T/in_bb"
for src in "$T/in_fifo" /dev/zero; do
    refused timeout 20 "$RTO" sort "$src" -o "$T/in_out" && has "not a regular file" err
    refused timeout 20 "$RTO" check-sort --expected "$T/in_sb" --gpu "$src" && has "not a regular file" err
    refused timeout 20 "$RTO" check-bvh --expected "$T/in_bb" --gpu "$src" && has "not a regular file" err
    # the same inside the bundles: the manifest, and an array the manifest's sha256 is checked against
    for b in in_sb/manifest.json in_bb/manifest.json in_bb/blas_0_order.npy; do
        mv "$T/$b" "$T/in_saved" && ln -s "$src" "$T/$b"
        case $b in
        in_sb/*) refused timeout 20 "$RTO" check-sort --expected "$T/in_sb" --gpu "$T/in_k.npy" ;;
        *) refused timeout 20 "$RTO" check-bvh --expected "$T/in_bb" --gpu "$T/in_bb/blas_0_nodes.npy" --blas 0 ;;
        esac && has "not a regular file" err
        rm "$T/$b" && mv "$T/in_saved" "$T/$b"
    done
done
[ -e "$T/in_out" ] && fail "a refused sort wrote its output"
# control: the restored bundles still check
run 0 "$RTO" check-bvh --expected "$T/in_bb" --gpu "$T/in_bb/blas_0_nodes.npy" --blas 0

# a failed write of the description is an error, not a silent exit 0
if [ -w /dev/full ]; then
    for json in --json ""; do
        "$RTO" info triangle $json >/dev/full 2>"$T/err"
        rc=$?
        [ $rc = 2 ] && [ "$(wc -l <"$T/err")" = 1 ] || fail "info $json >/dev/full: exit $rc, $(cat "$T/err")"
    done
fi
no_temporaries "end"

finish "all output-safety checks passed"

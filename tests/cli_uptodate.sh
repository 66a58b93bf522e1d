#!/usr/bin/env bash
# Up-to-date bundles: a second identical run of suite / sort / build / trace / render leaves the bundle alone (no
# file's inode, size, mtime or ctime changes), while a changed parameter or input file, --force, a modified or a
# removed file of the bundle make it written again — and what is written again is byte-identical to a fresh write.
#   bash tests/cli_uptodate.sh RTORACLE FIXTURES
set -u
RTO=$1
FIX=$2
. "$(dirname "$0")/cli_lib.sh"

# The record lives in a user extended attribute; a scratch file system without them cannot skip anything.
if command -v python3 >/dev/null &&
    ! python3 -c "import os,sys; os.setxattr(sys.argv[1], 'user.rtoracle.probe', b'1')" "$T" 2>/dev/null; then
    echo "SKIP: $T has no user extended attributes"
    exit 77
fi

# snap DIR: every entry with its inode, size, mtime and ctime (a rewrite or a rename changes some of them).
snap() { (cd "$1" && find . -printf '%p %i %s %T@ %C@\n' | LC_ALL=C sort); }
# same_as_before DIR WHAT: DIR is exactly as in $T/DIR.snap.
same_as_before() { snap "$1" >"$T/now.snap"; cmp -s "$T/now.snap" "$1.snap" || fail "$2: $1 was rewritten"; }
changed_since() { snap "$1" >"$T/now.snap"; cmp -s "$T/now.snap" "$1.snap" && fail "$2: $1 was not rewritten"; }
# fresh_equal DIR CMD...: CMD -o a new directory writes the same bytes as DIR holds.
fresh_equal() {
    local dir=$1
    shift
    rm -rf "$T/fresh"
    "$@" -o "$T/fresh" >/dev/null 2>&1 || fail "fresh write failed: $*"
    diff -r "$dir" "$T/fresh" >/dev/null || fail "$dir differs from a fresh write of: $*"
}

cd "$T" || exit 1
cp -r "$FIX/Box" box

# --- every command: the second run skips, in one line, and touches nothing ------------------------------------
SUITE=("$RTO" suite sort --sizes tiny --formats u32 --dists uniform,clustered)
run 0 "${SUITE[@]}" -o suite && has "16 cases written" out
snap suite >suite.snap
run 0 "${SUITE[@]}" -o suite && has "suite is up to date" out
[ "$(wc -l <"$T/out")" = 1 ] || fail "suite: more than one line for an up-to-date suite"
same_as_before suite "suite, second run"
# The same options spelled otherwise are the same request.
run 0 "$RTO" suite sort --dists=uniform,clustered --formats=u32 --sizes=tiny -o suite && has "up to date" out

run 0 "$RTO" keys --dist uniform --n 300 -o keys.npy
run 0 "$RTO" sort keys.npy --checkpoints -o sorted && snap sorted >sorted.snap
run 0 "$RTO" sort keys.npy --checkpoints -o sorted && has "sorted is up to date" out
same_as_before sorted "sort, second run"

run 0 "$RTO" build box/glTF/Box.gltf -o build && snap build >build.snap
run 0 "$RTO" build box/glTF/Box.gltf -o build && has "build is up to date" out
same_as_before build "build, second run"

run 0 "$RTO" trace triangle --width 32 --height 24 -o trace && snap trace >trace.snap
run 0 "$RTO" trace triangle --width=32 --height=24 --threads 1 -o trace && has "trace is up to date" out
same_as_before trace "trace, second run (other spelling, other thread count)"

run 0 "$RTO" render box/glTF/Box.gltf --program sun-shadow --width 24 --height 16 -o frame
snap frame >frame.snap
run 0 "$RTO" render box/glTF/Box.gltf --program sun-shadow --width 24 --height 16 -o frame
has "frame is up to date" out
same_as_before frame "render, second run"

# --- a changed parameter or input file writes again ---------------------------------------------------------
run 0 "$RTO" trace triangle --width 32 --height 25 -o trace
grep -q "up to date" "$T/out" && fail "trace: another --height was skipped"
changed_since trace "trace, another --height"
fresh_equal trace "$RTO" trace triangle --width 32 --height 25

run 0 "$RTO" suite sort --sizes tiny --formats u32 --dists uniform,clustered --seed 2 -o suite
has "16 cases written" out
snap suite >suite.snap

# Touching an input without changing it is not a change (contents are compared, not times) ...
touch box/glTF/Box0.bin box/glTF/Box.gltf
run 0 "$RTO" build box/glTF/Box.gltf -o build && has "up to date" out
same_as_before build "build, inputs touched but unchanged"
# ... changing the scene file or one of its buffers is.
printf '\n' >>box/glTF/Box.gltf
run 0 "$RTO" build box/glTF/Box.gltf -o build
grep -q "up to date" "$T/out" && fail "build: a changed .gltf was skipped"
changed_since build "build, .gltf changed" && snap build >build.snap
printf '\0\0\0\0' | dd of=box/glTF/Box0.bin bs=1 seek=0 conv=notrunc 2>/dev/null # the first index: still valid
run 0 "$RTO" build box/glTF/Box.gltf -o build
changed_since build "build, .bin changed"
fresh_equal build "$RTO" build box/glTF/Box.gltf

run 0 "$RTO" keys --dist uniform --n 300 --seed 7 -o keys.npy
run 0 "$RTO" sort keys.npy --checkpoints -o sorted
changed_since sorted "sort, other keys in the same file"
fresh_equal sorted "$RTO" sort keys.npy --checkpoints

# --force writes an up-to-date bundle again, byte for byte the same.
snap frame >frame.snap
run 0 "$RTO" render box/glTF/Box.gltf --program sun-shadow --width 24 --height 16 --force -o frame
changed_since frame "render --force"

# --- a bundle modified after it was written: named on stderr, written again, whole --------------------------
sleep 0.05 # a later mtime than the bundle's own, whatever the clock's grain
snap suite >suite.snap
case_dir=$(cd suite && ls -d bitonic-u32-clustered-n* | head -1)
# An array identical in several cases is one file (hard links, see cli_share.sh): an in-place edit changes each of
# its names, and the first of them in the suite's order is the one named.
names=$(find suite -samefile "suite/$case_dir/sorted.npy")
printf '\x01' | dd of="suite/$case_dir/sorted.npy" bs=1 seek=200 conv=notrunc 2>/dev/null
run 0 "$RTO" suite sort --sizes tiny --formats u32 --dists uniform,clustered --seed 2 -o suite
has "16 cases written" out
has "was modified after the bundle was written; writing it again" err
named=$(sed -n 's/.*: \(suite\/[^ ]*\) was modified after.*/\1/p' "$T/err")
grep -qxF -- "$named" <<<"$names" || fail "suite: named '$named', not a name of the file modified ($names)"
fresh_equal suite "$RTO" suite sort --sizes tiny --formats u32 --dists uniform,clustered --seed 2

rm build/tlas_nodes.npy
run 0 "$RTO" build box/glTF/Box.gltf -o build
has "build/tlas_nodes.npy is missing; writing it again" err
[ -f build/tlas_nodes.npy ] || fail "build: the removed file was not written again"
fresh_equal build "$RTO" build box/glTF/Box.gltf

# A file of the user's in an up-to-date bundle is left alone, and so is the bundle; with other arguments the
# bundle is not ours to replace any more (as before): refused, nothing deleted.
echo notes >trace/NOTES.txt
snap trace >trace.snap
run 0 "$RTO" trace triangle --width 32 --height 25 -o trace && has "up to date" out
same_as_before trace "trace with a user's file"
run 2 "$RTO" trace triangle --width 32 --height 26 -o trace && has "not listed in its manifest.json" err
[ -f trace/NOTES.txt ] || fail "trace: the user's file was deleted"

# An input modified while a command runs (here: dated after the command started) leaves its bundle unstamped, so
# the next run writes it again rather than trusting outputs made from what it read before the change.
touch -d '+1 hour' box/glTF/Box.gltf
run 0 "$RTO" build box/glTF/Box.gltf -o build2 && snap build2 >build2.snap
touch -d '-1 hour' box/glTF/Box.gltf
run 0 "$RTO" build box/glTF/Box.gltf -o build2
grep -q "up to date" "$T/out" && fail "build: a bundle made while its input changed was trusted"
changed_since build2 "build, input changed during the run"
run 0 "$RTO" build box/glTF/Box.gltf -o build2 && has "up to date" out

finish "cli_uptodate: second runs write nothing; changed parameters, inputs and bundle files are written again"

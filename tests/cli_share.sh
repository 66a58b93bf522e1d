#!/usr/bin/env bash
# Shared arrays in a suite: identical arrays of the cases are one file (hard links) exactly where their bytes are the
# same, the suite is byte for byte the one --no-share writes, every case still checks as a bundle, a re-run that
# changes nothing still skips, and --force writes it all again.
#   bash tests/cli_share.sh RTORACLE
set -u
RTO=$1
. "$(dirname "$0")/cli_lib.sh"

cd "$T" || exit 1
SUITE=("$RTO" suite sort --sizes tiny,64,257 --dists uniform,sorted,reversed,clustered,all-equal,sentinel-heavy)
run 0 "${SUITE[@]}" -o shared && has "cases written" out
run 0 "${SUITE[@]}" --no-share -o copies && has "cases written" out
[ "$failures" = 0 ] || finish "unreachable" # no suites to look at

# The same bytes, manifests included, whichever way they are stored.
diff -r shared copies >/dev/null || fail "a shared suite differs from the one --no-share writes"
[ -z "$(find copies -type f -links +1)" ] || fail "--no-share: hard links in the suite"

# linked <=> identical: every .npy's content (sha256sum, independent of rtoracle) and inode; a content held by two
# inodes is an identical array written twice, an inode with two contents cannot be (a check of the check).
(cd shared && find . -name '*.npy' -printf '%i %p\n' | LC_ALL=C sort -k2) >inodes
(cd shared && find . -name '*.npy' -print0 | xargs -0 sha256sum | awk '{print $1, $2}' | LC_ALL=C sort -k2) >sums
join -1 2 -2 2 inodes sums | awk '{print $2, $3}' | LC_ALL=C sort -u >pairs
[ "$(wc -l <inodes)" = "$(wc -l <sums)" ] || fail "inode and content lists differ in length"
twice=$(awk '{n[$2]++} END {for (c in n) if (n[c] > 1) print c}' pairs)
[ -z "$twice" ] || fail "identical arrays written as separate files: $(echo "$twice" | head -3)"
mixed=$(awk '{n[$1]++} END {for (i in n) if (n[i] > 1) print i}' pairs)
[ -z "$mixed" ] || fail "one inode with two contents: $mixed"
files=$(wc -l <inodes)
unique=$(awk '{print $1}' pairs | LC_ALL=C sort -u | wc -l)
[ "$unique" -lt "$files" ] || fail "no array shared at all ($files files)"

# The measured pairs, checked with cmp: a bitonic case and the radix case of the same input hold the same keys.npy
# and sorted.npy, and perm.npy where the two permutations agree; each is one file exactly when cmp finds them equal.
declare -A ino nlink
while read -r i h p; do ino[$p]=$i nlink[$p]=$h; done < <(cd shared && find . -name '*.npy' -printf '%i %n %P\n')
pairs_linked=0
for b in shared/bitonic-*; do
    b=${b#shared/}
    r=radix-${b#bitonic-}
    for f in keys.npy sorted.npy perm.npy; do
        if cmp -s "shared/$b/$f" "shared/$r/$f"; then
            [ "${ino[$b/$f]}" = "${ino[$r/$f]}" ] || fail "$b/$f and $r/$f are identical but not one file"
            pairs_linked=$((pairs_linked + 1))
        else
            [ "${ino[$b/$f]}" != "${ino[$r/$f]}" ] || fail "$b/$f and $r/$f are one file but differ"
        fi
    done
    [ "${nlink[$b/keys.npy]}" -ge 2 ] || fail "$b/keys.npy has no second link"
done
[ $pairs_linked -gt 0 ] || fail "no bitonic / radix pair shares a file"

# Every case of the shared suite is a complete bundle: its input verified by sha256, its sorted keys pass.
for c in shared/bitonic-u32-sorted-n257 shared/radix-u64-clustered-n257 shared/radix-u32-all-equal-n64; do
    run 0 "$RTO" check-sort --expected "$c" --input "$c/keys.npy" --gpu "$c/sorted.npy" --no-artifacts
done

# Up to date: a second run (with or without --no-share: how files are stored is not part of the request) touches
# nothing; --force writes everything again, the same bytes, shared again.
snap() { (cd "$1" && find . -printf '%p %i %s %n %T@ %C@\n' | LC_ALL=C sort); }
if command -v python3 >/dev/null &&
    python3 -c "import os,sys; os.setxattr(sys.argv[1], 'user.rtoracle.probe', b'1')" "$T" 2>/dev/null; then
    snap shared >before
    run 0 "${SUITE[@]}" -o shared && has "up to date" out
    run 0 "${SUITE[@]}" --no-share -o shared && has "up to date" out
    snap shared >after
    cmp -s before after || fail "an up-to-date shared suite was touched"
else
    echo "note: $T has no user extended attributes; the up-to-date part is skipped"
fi
old_ino=$(stat -c %i shared/bitonic-u32-uniform-n1/keys.npy)
run 0 "${SUITE[@]}" --force -o shared && has "cases written" out
[ "$(stat -c %i shared/bitonic-u32-uniform-n1/keys.npy)" != "$old_ino" ] || fail "--force: a file kept its inode"
diff -r shared copies >/dev/null || fail "--force: the suite differs from the one --no-share writes"
[ "$(stat -c %i shared/bitonic-u32-uniform-n1/keys.npy)" = "$(stat -c %i shared/radix-u32-uniform-n1/keys.npy)" ] ||
    fail "--force: keys.npy no longer shared"

finish "cli_share: $files arrays in $unique files; linked exactly where identical; same bytes as --no-share"

#!/usr/bin/env bash
# Command-line tests of keys / sort / check-sort / suite: exit statuses, every mutation named with its slot (and
# pass), malformed inputs refused with one line and status 2, no partial output, byte-identical reruns.
set -u
RTO=$1
MUT=$2
. "$(dirname "$0")/cli_lib.sh"

# --help of every command, usage errors
for c in keys sort check-sort suite; do
    run 0 "$RTO" "$c" --help && has usage out
done
run 2 "$RTO"
run 2 "$RTO" frobnicate
run 2 "$RTO" keys --dist random --n 10
run 2 "$RTO" keys --dist random --n 12x -o "$T/x.npy"
run 2 "$RTO" keys --dist random --n 999999999999 -o "$T/x.npy" && has "--n" err
run 2 "$RTO" keys --dist no-such --n 10 -o "$T/x.npy" && has "unknown distribution" err
run 2 "$RTO" keys --dist uniform --n 65537 -o "$T/x.npy" && has "65536" err
# memory: the keys (and the sort buffer of sorted / reversed) against --memory-budget, refused before any work
bounded 2 "keys 2^28 u64 over the budget" "$RTO" keys --dist uniform --n 268435456 --format u64 --memory-budget 1024 \
    -o "$T/x.npy" && has "268435456 u64 keys of 'uniform' may hold up to 2.00 GiB at once, over the memory budget of 1.00 GiB" err
bounded 2 "keys 2^27 sorted over the budget" "$RTO" keys --dist sorted --n 134217728 --format u64 --memory-budget 1536 \
    -o "$T/x.npy" && has "up to 2.00 GiB" err
[ -e "$T/x.npy" ] && fail "a refused keys request wrote output"
run 0 "$RTO" keys --dist uniform --n 131072 --format u64 --memory-budget 4 -o "$T/x.npy"
rm -f "$T/x.npy"
run 2 "$RTO" sort --algo quick "$T/x.npy" -o "$T/o"
[ -e "$T/x.npy" ] && fail "a refused keys command left $T/x.npy"

# control: a correct sort passes, for both formats, dump lengths n and n_padded
for fmt in u32 u64; do
    run 0 "$RTO" keys --dist clustered --n 4097 --format $fmt --seed 3 -o "$T/k_$fmt.npy"
    run 0 "$RTO" sort "$T/k_$fmt.npy" --checkpoints -o "$T/b_$fmt"
    run 0 "$RTO" check-sort --input "$T/k_$fmt.npy" --gpu "$T/b_$fmt/sorted.npy" && has "^PASS" out
    run 0 "$RTO" check-sort --input "$T/k_$fmt.npy" --gpu "$T/b_$fmt/sorted.npy" --gpu-passes "$T/b_$fmt/passes.npy"
    run 0 "$RTO" check-sort --expected "$T/b_$fmt" --gpu "$T/b_$fmt/sorted.npy" --json && has '"result": "pass"' out
done

# mutations of the final array: exit 1, fault class and first bad slot named, in JSON and in the text report
for m in swap-adjacent:order dup-neighbour:duplicate-key drop-sentinel:lost-key flip-bit:corrupt-key; do
    for fmt in u32 u64; do
        slot=$("$MUT" "${m%%:*}" "$T/b_$fmt/sorted.npy" "$T/g.npy") || { fail "npy_mutate ${m%%:*}"; continue; }
        run 1 "$RTO" check-sort --input "$T/k_$fmt.npy" --gpu "$T/g.npy" --json --no-artifacts &&
            has "\"fault\": \"${m#*:}\"" out && loc slot "$slot"
        run 1 "$RTO" check-sort --input "$T/k_$fmt.npy" --gpu "$T/g.npy" &&
            has "^FAIL ${m#*:}" out && has "slot $slot" out
        [ -f "$T/g.npy.check-sort.json" ] || fail "no report artefact next to the GPU dump for ${m%%:*}"
        rm -f "$T/g.npy.check-sort.json"
    done
done

# a corrupted checkpoint pass: named by pass index (k, j) and slot
read -r pass slot < <("$MUT" corrupt-pass "$T/b_u32/passes.npy" "$T/gp.npy")
run 1 "$RTO" check-sort --input "$T/k_u32.npy" --gpu "$T/b_u32/sorted.npy" --gpu-passes "$T/gp.npy" --json \
    --no-artifacts && has '"fault": "pass"' out && loc pass "$pass" && loc slot "$slot"

# stability: a radix bundle of few-unique keys, zipped into {key, value} records, then two equal keys reordered
run 0 "$RTO" keys --dist few-unique --n 3000 -o "$T/fu.npy"
run 0 "$RTO" sort "$T/fu.npy" --algo radix --radix-bits 4 --tile 64 -o "$T/rb"
"$MUT" zip "$T/rb/sorted.npy" "$T/rb/perm.npy" "$T/pairs.npy" || fail "zip"
run 0 "$RTO" check-sort --expected "$T/rb" --gpu "$T/pairs.npy" && has "stable       ok" out
run 0 "$RTO" check-sort --input "$T/fu.npy" --gpu "$T/rb/sorted.npy" --gpu-values "$T/rb/perm.npy" --stable
slot=$("$MUT" swap-values "$T/pairs.npy" "$T/pairs_bad.npy")
run 1 "$RTO" check-sort --expected "$T/rb" --gpu "$T/pairs_bad.npy" --no-artifacts &&
    has "^FAIL stability" out && has "slots $slot and" out
run 0 "$RTO" check-sort --input "$T/fu.npy" --gpu "$T/pairs_bad.npy" # bitonic promises no stability
run 2 "$RTO" check-sort --input "$T/fu.npy" --gpu "$T/rb/sorted.npy" --stable && has "values" err
# radix checkpoints: the bundle's scatter arrays pass, a corrupted one is named
run 0 "$RTO" check-sort --expected "$T/rb" --gpu "$T/pairs.npy" --gpu-passes "$T/rb/radix_scatter.npy"
read -r pass slot < <("$MUT" corrupt-pass "$T/rb/radix_scatter.npy" "$T/rp.npy")
run 1 "$RTO" check-sort --expected "$T/rb" --gpu "$T/pairs.npy" --gpu-passes "$T/rp.npy" --no-artifacts &&
    has "^FAIL pass: radix pass $pass" out && has "slot $slot" out

# the oracle's own key/value output passes for every distribution (bundles hold n slots): a sentinel-heavy dump of n
# slots carries padding indices >= n in its values, as docs/sort.md allows (regression: refused as out of range)
stride=$(sampled 4) k=0
while read -r dist; do
    k=$((k + 1))
    [ $((k % stride)) = 0 ] || [ "$dist" = sentinel-heavy ] || continue
    for fmt in u32 u64; do
        "$RTO" keys --dist "$dist" --n 1000 --format $fmt -o "$T/d.npy" 2>/dev/null || continue # u64-only dists
        run 0 "$RTO" sort "$T/d.npy" -o "$T/db" &&
            run 0 "$RTO" check-sort --expected "$T/db" --gpu "$T/db/sorted.npy" --gpu-values "$T/db/perm.npy"
        run 0 "$RTO" sort "$T/d.npy" --algo radix -o "$T/dr" &&
            run 0 "$RTO" check-sort --expected "$T/dr" --gpu "$T/dr/sorted.npy" --gpu-values "$T/dr/perm.npy"
    done
done < <("$RTO" keys --list | awk '/^size classes/ {exit} /^  [a-z]/ {print $1}')
"$RTO" keys --dist sentinel-heavy --n 1000 -o "$T/d.npy" && "$RTO" sort "$T/d.npy" -o "$T/db" >/dev/null
"$MUT" zip "$T/db/sorted.npy" "$T/db/perm.npy" "$T/dpairs.npy" || fail "zip"
run 0 "$RTO" check-sort --expected "$T/db" --gpu "$T/dpairs.npy" --json && has '"result": "pass"' out

# malformed .npy: every truncation of a small file, bad magic, wrong dtype, fortran order, shape mismatch
run 0 "$RTO" keys --dist random --n 17 -o "$T/s.npy"
size=$(stat -c %s "$T/s.npy")
for ((i = 0; i < size; i += $(sampled 3))); do
    head -c "$i" "$T/s.npy" >"$T/t.npy"
    "$RTO" sort "$T/t.npy" -o "$T/tout" >"$T/out" 2>"$T/err"
    rc=$?
    if [ $rc != 2 ] || [ "$(wc -l <"$T/err")" != 1 ] || [ -e "$T/tout" ]; then
        fail "truncated at $i bytes: exit $rc, stderr: $(head -c 300 "$T/err")"
    fi
done
printf 'GARBAGE!' | cat - "$T/s.npy" >"$T/t.npy"
run 2 "$RTO" sort "$T/t.npy" -o "$T/tout" && has "magic" err
LC_ALL=C sed 's/<u4/<f4/' "$T/s.npy" >"$T/t.npy"
run 2 "$RTO" sort "$T/t.npy" -o "$T/tout" && has "float32" err
LC_ALL=C sed "s/'fortran_order': False/'fortran_order': True /" "$T/s.npy" >"$T/t.npy"
run 2 "$RTO" sort "$T/t.npy" -o "$T/tout" && has "fortran" err
LC_ALL=C sed 's/(17,)/(18,)/' "$T/s.npy" >"$T/t.npy"
run 2 "$RTO" sort "$T/t.npy" -o "$T/tout" && has "truncated" err
LC_ALL=C sed 's/(17,)/(16,)/' "$T/s.npy" >"$T/t.npy"
run 2 "$RTO" sort "$T/t.npy" -o "$T/tout" && has "trailing" err
run 2 "$RTO" check-sort --input "$T/s.npy" --gpu "$T/b_u64/sorted.npy" && has "uint64" err
run 2 "$RTO" check-sort --input "$T/s.npy" --gpu "$T/b_u32/passes.npy" && has "1-D" err
run 2 "$RTO" check-sort --expected "$T/b_u32" --input "$T/s.npy" --gpu "$T/b_u32/sorted.npy" && has "not the input" err
printf '{"format": "rtoracle-bundle", "format_version": 99}' >"$T/fake_manifest.json"
mkdir -p "$T/future" && cp "$T/fake_manifest.json" "$T/future/manifest.json"
run 2 "$RTO" check-sort --expected "$T/future" --gpu "$T/b_u32/sorted.npy" && has "version 99" err
# a bundle whose file changed after it was written is refused by sha256
cp -r "$T/b_u32" "$T/b_tampered" && "$MUT" flip-bit "$T/b_u32/keys.npy" "$T/b_tampered/keys.npy" >/dev/null
run 2 "$RTO" check-sort --expected "$T/b_tampered" --gpu "$T/b_u32/sorted.npy" && has "sha256" err
[ -e "$T/tout" ] && fail "a refused sort left $T/tout"

# no partial output: an existing non-bundle directory is never replaced; a suite failing midway leaves nothing
mkdir -p "$T/precious" && echo keep >"$T/precious/notes.txt"
run 2 "$RTO" sort "$T/s.npy" -o "$T/precious" && has "not an rtoracle bundle" err
[ -f "$T/precious/notes.txt" ] || fail "sort replaced a non-bundle directory"
run 2 "$RTO" suite sort --dists random --formats u32 --algos bitonic --sizes 3,16777216 --checkpoint-max 16777216 \
    -o "$T/half" && has "GiB" err
[ -e "$T/half" ] && fail "a failed suite left its output directory"
ls "$T" | grep -q '\.tmp\.' && fail "temporary directories left behind: $(ls "$T" | grep '\.tmp\.')"

# determinism: the same inputs give byte-identical bundles, also when a bundle is replaced
run 0 "$RTO" sort "$T/k_u32.npy" --checkpoints -o "$T/b_again"
diff -r "$T/b_u32" "$T/b_again" >/dev/null || fail "two sort runs differ"
run 0 "$RTO" sort "$T/k_u32.npy" --checkpoints -o "$T/b_again"
diff -r "$T/b_u32" "$T/b_again" >/dev/null || fail "replacing a bundle changed its bytes"
run 0 "$RTO" suite sort --sizes tiny,tile --dists clustered,few-unique,digit-5-one-bucket -o "$T/s1" && has "cases" out
run 0 "$RTO" suite sort --sizes tiny,tile --dists clustered,few-unique,digit-5-one-bucket -o "$T/s2"
diff -r "$T/s1" "$T/s2" >/dev/null || fail "two suite runs differ"
n_cases=$(grep -c '"case": "sort:' "$T/s1/manifest.json")
# 2 algos x (2 dists x 2 formats + digit-5 in u64 only) x 16 sizes
[ "$n_cases" = 160 ] || fail "suite wrote $n_cases cases, expected 160"
[ -f "$T/s1/bitonic-u32-clustered-n257/passes.npy" ] || fail "suite case without checkpoints"
run 0 "$RTO" check-sort --expected "$T/s1/radix-u64-few-unique-n4097" --gpu "$T/s1/radix-u64-few-unique-n4097/sorted.npy"

finish "all command-line checks passed"

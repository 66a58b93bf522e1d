#!/usr/bin/env bash
# check-sort --expected compares the dump with the bundle's sorted.npy: the verdicts and named faults equal those of
# --input (which sorts the input itself); a sorted.npy that is not the input sorted, or has the wrong shape, is
# refused with status 2 and one line; a bundle without sorted.npy is still checked from its input. --threads does not
# change a verdict or a report.
set -u
RTO=$1
MUT=$2
EDIT=$3
. "$(dirname "$0")/cli_lib.sh"

for fmt in u32 u64; do
    run 0 "$RTO" keys --dist few-unique --n 4097 --format $fmt --seed 7 -o "$T/k.npy"
    run 0 "$RTO" sort "$T/k.npy" -o "$T/b"
    run 0 "$RTO" check-sort --expected "$T/b" --gpu "$T/b/sorted.npy" && has "^PASS" out
    for m in swap-adjacent dup-neighbour drop-sentinel flip-bit; do
        "$MUT" "$m" "$T/b/sorted.npy" "$T/g.npy" >/dev/null || { fail "npy_mutate $m"; continue; }
        run 1 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/g.npy" --json --no-artifacts && cp "$T/out" "$T/want"
        run 1 "$RTO" check-sort --expected "$T/b" --gpu "$T/g.npy" --json --no-artifacts
        # the same report but for the case id the bundle adds
        diff <(grep -v '"what"' "$T/want") <(grep -v '"what"' "$T/out") >/dev/null ||
            fail "$fmt $m: --expected and --input reports differ"
    done
    # a sorted.npy edited (and its sha256 rewritten) so that it is no longer the input sorted
    rm -rf "$T/e" && cp -r "$T/b" "$T/e"
    "$EDIT" "$T/e/sorted.npy" set-u32 0 0xFFFFFFFF >/dev/null
    run 2 "$RTO" check-sort --expected "$T/e" --gpu "$T/b/sorted.npy" && has "not the bundle's input" err
    [ "$(wc -l <"$T/err")" = 1 ] || fail "more than one line on stderr"
    rm -rf "$T/e" && cp -r "$T/b" "$T/e"
    "$EDIT" "$T/e/sorted.npy" truncate 100 >/dev/null
    run 2 "$RTO" check-sort --expected "$T/e" --gpu "$T/b/sorted.npy" && has "sorted.npy holds" err
    # a sorted.npy changed after the bundle was written: refused by sha256
    rm -rf "$T/e" && cp -r "$T/b" "$T/e"
    "$MUT" flip-bit "$T/b/sorted.npy" "$T/e/sorted.npy" >/dev/null
    run 2 "$RTO" check-sort --expected "$T/e" --gpu "$T/b/sorted.npy" && has "sha256" err
    # a bundle whose sorted.npy is gone is checked from its input alone
    rm "$T/e/sorted.npy"
    run 0 "$RTO" check-sort --expected "$T/e" --gpu "$T/b/sorted.npy" && has "^PASS" out
    "$MUT" swap-adjacent "$T/b/sorted.npy" "$T/g.npy" >/dev/null
    run 1 "$RTO" check-sort --expected "$T/e" --gpu "$T/g.npy" --no-artifacts && has "^FAIL order" out
done

# --threads: above the size where the input's matcher starts workers (2^17 keys), 1, 3 and every thread give the
# same verdict and, on a fault, the same report; a count past 256 is refused with status 2.
run 0 "$RTO" keys --dist random --n 140001 --format u64 --seed 3 -o "$T/big.npy"
run 0 "$RTO" sort "$T/big.npy" -o "$T/bb"
for t in 1 3 0; do
    run 0 "$RTO" check-sort --input "$T/big.npy" --gpu "$T/bb/sorted.npy" --threads $t && has "^PASS" out
done
for m in swap-adjacent flip-bit; do
    "$MUT" "$m" "$T/bb/sorted.npy" "$T/g.npy" >/dev/null || { fail "npy_mutate $m"; continue; }
    run 1 "$RTO" check-sort --input "$T/big.npy" --gpu "$T/g.npy" --threads 1 --json --no-artifacts &&
        cp "$T/out" "$T/want"
    for t in 3 0; do
        run 1 "$RTO" check-sort --input "$T/big.npy" --gpu "$T/g.npy" --threads $t --json --no-artifacts
        cmp -s "$T/want" "$T/out" || fail "$m: the report with --threads $t differs from --threads 1"
    done
done
run 2 "$RTO" check-sort --input "$T/big.npy" --gpu "$T/bb/sorted.npy" --threads 257

finish "check-sort --expected and --threads checks passed"

#!/usr/bin/env bash
# fuzz_run.sh NAME TARGET RUNS FIXTURES: a short libFuzzer run of one fuzz target, as the test suite makes it: the
# target's seed corpus written afresh into a scratch directory (npy: tests/tools/npy_corpus.py; gltf:
# tests/tools/gltf_corpus.py over the fixtures and assimp-testmodels; check_hits / check_frame: the bundle and dump
# files the target writes itself under RTO_FUZZ_SEEDS), then RUNS executions from a fixed PRNG seed. Inputs the run
# finds worth keeping go to the scratch directory too, never into the source tree. Exit 0 when nothing was found; a
# crash, leak, sanitizer report, invariant failure or time-out fails the test with libFuzzer's own report.
set -u
name=$1
target=$2
runs=$3
fixtures=$4
tools=$(dirname "$0")/tools
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
mkdir "$T/seeds" "$T/found"
case $name in
npy) python3 "$tools/npy_corpus.py" "$T/seeds" ;;
gltf) python3 "$tools/gltf_corpus.py" "$T/seeds" "$fixtures" /usr/share/assimp/models >/dev/null ;;
*) RTO_FUZZ_SEEDS="$T/seeds" "$target" 2>/dev/null ;;
esac || { echo "FAIL: writing the $name seeds"; exit 1; }
seeds=$(find "$T/seeds" -type f | wc -l)
[ "$seeds" -gt 0 ] || { echo "FAIL: no $name seeds"; exit 1; }
# -close_fd_mask=1: the command targets print their verdicts on stdout; -timeout / -rss_limit_mb: one input may take
# at most 60 s and 2 GB; -print_final_stats for the figures below.
"$target" -runs="$runs" -seed=1 -timeout=60 -rss_limit_mb=2048 -close_fd_mask=1 -print_final_stats=1 \
    "$T/found" "$T/seeds" >"$T/log" 2>&1
rc=$?
if [ "$rc" != 0 ]; then
    tail -n 60 "$T/log"
    echo "FAIL: fuzz_$name exited $rc after at most $runs executions (above: libFuzzer's report)"
    exit 1
fi
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$T/log")
echo "fuzz_$name: $seeds seeds, ${execs:-?} executions, nothing found"

#!/usr/bin/env bash
# Regenerates the committed golden bundles in fixtures/golden/ on purpose, after a deliberate change of output:
#   bash scripts/update-goldens.sh        (then review `git status fixtures/golden` and commit)
# tests/golden.sh (run by scripts/test.sh) fails on any byte that differs from what is committed.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/deps.sh
rto_install_deps
rto_build build --werror
tmp=$(mktemp -d golden.tmp.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
bash scripts/goldens.sh build/oracle/rtoracle "$tmp/golden"
(cd "$tmp/golden" && find . -type f ! -name SHA256SUMS | LC_ALL=C sort | sed 's|^\./||' | xargs sha256sum >SHA256SUMS)
# Replace only fixtures/golden, which holds nothing but generated bundles and SHA256SUMS.
rm -rf fixtures/golden
mv "$tmp/golden" fixtures/golden
echo "rtoracle: fixtures/golden regenerated ($(wc -l <fixtures/golden/SHA256SUMS) files); review and commit"

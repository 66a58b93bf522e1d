#!/usr/bin/env bash
# The main job: install what is missing, build everything, and write the golden bundles to out/goldens/.
#   bash scripts/main.sh [extra arguments for `rtoracle suite sort`]
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/deps.sh
rto_install_deps
rto_build build --werror
out=out/goldens
mkdir -p "$out"
# The sort matrix a GPU harness runs: every distribution x size class x format x algorithm (about 700 MB).
build/oracle/rtoracle suite sort -o "$out/sort" "$@"
echo "rtoracle: built build/oracle/rtoracle; golden bundles in $out/"

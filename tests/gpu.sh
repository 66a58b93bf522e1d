#!/usr/bin/env bash
# The WebGPU backend's test: gpu/run's ci subset (every sort kernel over the matrix up to 4097 keys, one TLAS build,
# one traced frame of triangle and of sun-shadow at 64x64 on rtstress:4) must pass, and each planted fault must be
# reported by the oracle exactly where it starts.
#   bash tests/gpu.sh RTORACLE OUTDIR
set -euo pipefail
rto=$1
out=$2
rm -rf "$out"
mkdir -p "$out"
gpu/run --rtoracle "$rto" --subset ci --json "$out/ci.json" --html "$out/ci.html"
echo "gpu: the ci subset passes ($out/ci.html)"

#!/usr/bin/env bash
# Command-line tests of the option parser shared by every command: one-line usage errors, strict numbers, both sides
# of every bounded option, repeated list items, and the command seeing only the public header.
set -u
RTO=$1
SRC=$2
. "$(dirname "$0")/cli_lib.sh"

# one_line TEXT : the last command printed exactly TEXT as its only stderr line, and nothing on stdout.
one_line() {
    [ "$(wc -l <"$T/err")" = 1 ] ||
        { fail "expected one line on stderr, got $(wc -l <"$T/err")"; sed 's/^/    | /' "$T/err" | head -5; }
    [ "$(cat "$T/err")" = "$1" ] || fail "stderr is '$(head -c 300 "$T/err")', want '$1'"
    [ -s "$T/out" ] && fail "unexpected stdout: $(head -c 200 "$T/out")"
    return 0
}
# usage_line CMD TEXT : one_line "rtoracle CMD: TEXT (rtoracle CMD --help)", the shape of every usage error.
usage_line() { one_line "rtoracle $1: $2 (rtoracle $1 --help)"; }
# shape FILE N : FILE is a .npy of shape (N,), read from its header text.
shape() { head -c 128 "$1" | grep -aq "'shape': ($2,)" || fail "$1 does not have shape ($2,)"; }

# Inputs the commands below need.
run 0 "$RTO" keys --dist clustered --n 100 -o "$T/k.npy"
run 0 "$RTO" sort "$T/k.npy" -o "$T/b"
run 0 "$RTO" build triangle -o "$T/tri"

# --- an unknown option: one line naming it and where help is, exit 2; never the whole help ----------------------
for c in keys sort check-sort "suite sort" build check-bvh info; do
    name=${c%% *}
    run 2 "$RTO" $c --frob && usage_line $name "unknown option '--frob'"
    run 2 "$RTO" $c --frob=3 && usage_line $name "unknown option '--frob'"
    run 2 "$RTO" $c -x && usage_line $name "unknown option '-x'"
    run 0 "$RTO" $c --help && has "^usage: rtoracle $name" out && has "^  -h, --help" out
done
# An unknown command is one line too, naming it and where the list of commands is.
run 2 "$RTO" frob --help && one_line "rtoracle: unknown command 'frob' (rtoracle --help)"
# Long names are spelled out: no unique-prefix matching (getopt_long took --check for --checkpoints).
run 2 "$RTO" sort "$T/k.npy" --check -o "$T/p" && usage_line sort "unknown option '--check'"
# A flag takes no value.
run 2 "$RTO" info triangle --json=yes && usage_line info "option '--json' takes no value"

# --- a missing value: one line, exit 2, for every kind of value ----------------------------------------------------
run 2 "$RTO" build triangle -o && usage_line build "option '-o' needs a value"
run 2 "$RTO" build triangle -o "$T/x" --tlas &&
    usage_line build "option '--tlas' needs a value"
run 2 "$RTO" keys --dist uniform -o "$T/x.npy" --n && usage_line keys "option '--n' needs a value"
run 2 "$RTO" keys --dist --n 10 -o "$T/x.npy" && usage_line keys "option '--dist' needs a value"
run 2 "$RTO" suite sort -o "$T/s" --dists && usage_line suite "option '--dists' needs a value"
run 2 "$RTO" check-bvh --expected "$T/tri" --gpu && usage_line check-bvh "option '--gpu' needs a value"
run 2 "$RTO" sort "$T/k.npy" -o "$T/p" --radix-bits &&
    usage_line sort "option '--radix-bits' needs a value"
# A required option left out, a positional argument missing or extra.
run 2 "$RTO" check-bvh --gpu "$T/tri/tlas_nodes.npy" &&
    usage_line check-bvh "--expected is required"
run 2 "$RTO" sort -o "$T/p" && usage_line sort "expected one input keys.npy"
run 2 "$RTO" build triangle rtstress:2 -o "$T/p" && usage_line build "unexpected argument 'rtstress:2'"
[ -e "$T/x.npy" ] || [ -e "$T/x" ] || [ -e "$T/p" ] || [ -e "$T/s" ] && fail "a refused command left output behind"

# Options may follow positional arguments, take --name=VALUE and -oVALUE, and "--" ends them.
run 0 "$RTO" sort "$T/k.npy" --output="$T/eq" && [ -f "$T/eq/manifest.json" ] || fail "--output=DIR"
run 0 "$RTO" sort "-o$T/att" "$T/k.npy" && [ -f "$T/att/manifest.json" ] || fail "-oDIR"
cp "$T/k.npy" "$T/-k.npy"
run 0 env -C "$T" "$RTO" sort -o dd -- -k.npy && [ -f "$T/dd/manifest.json" ] || fail "-- before an argument"

# --- numbers: decimal (a leading zero is still decimal), 0x hexadecimal; nothing else ------------------------------
run 0 "$RTO" keys --dist uniform --n 010 -o "$T/n010.npy" && shape "$T/n010.npy" 10
run 0 "$RTO" keys --dist uniform --n 10 -o "$T/n10.npy" && shape "$T/n10.npy" 10
cmp -s "$T/n010.npy" "$T/n10.npy" || fail "--n 010 and --n 10 wrote different files"
run 0 "$RTO" keys --dist uniform --n 0x10 -o "$T/n0x10.npy" && shape "$T/n0x10.npy" 16
run 0 "$RTO" keys --dist uniform --n 0X1f -o "$T/n0x1f.npy" && shape "$T/n0x1f.npy" 31
run 0 "$RTO" keys --dist uniform --n=0 -o "$T/n0.npy" && shape "$T/n0.npy" 0
for bad in -1 +5 1e3 " 5" "5 " 5x 0x 0x-1 0b101 1.0 "" 18446744073709551616 99999999999999999999999999; do
    shown=${bad:-\'\'}
    run 2 "$RTO" keys --dist uniform --n "$bad" -o "$T/bad.npy" &&
        one_line "rtoracle keys: --n $shown: expected an integer 0 .. 268435456"
done
[ -e "$T/bad.npy" ] && fail "a refused --n wrote keys"

# --- bounded options: both sides of every boundary ----------------------------------------------------------------
# keys --n: 0 .. 2^28. The upper bound is accepted by the parser (the unknown distribution is what stops it).
run 2 "$RTO" keys --dist uniform --n 268435457 -o "$T/bad.npy" &&
    one_line "rtoracle keys: --n 268435457: expected an integer 0 .. 268435456"
run 2 "$RTO" keys --dist no-such --n 268435456 -o "$T/bad.npy" && has "unknown distribution" err
# --seed: 0 .. 2^32 - 1, in keys and suite.
run 0 "$RTO" keys --dist uniform --n 4 --seed 0 -o "$T/s0.npy"
run 0 "$RTO" keys --dist uniform --n 4 --seed 4294967295 -o "$T/smax.npy"
run 2 "$RTO" keys --dist uniform --n 4 --seed 4294967296 -o "$T/bad.npy" &&
    one_line "rtoracle keys: --seed 4294967296: expected an integer 0 .. 4294967295"
run 2 "$RTO" suite sort --seed 4294967296 -o "$T/bad" &&
    one_line "rtoracle suite: --seed 4294967296: expected an integer 0 .. 4294967295"
run 0 "$RTO" suite sort --seed 4294967295 --sizes 3 --dists uniform --formats u32 --algos bitonic -o "$T/sseed"
# --radix-bits: 4 or 8, in sort, check-sort and suite (a number: 0x8 is 8).
for bits in 4 8 0x8; do
    run 0 "$RTO" sort "$T/k.npy" --algo radix --radix-bits $bits -o "$T/rb$bits"
    run 0 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/b/sorted.npy" --algo radix --radix-bits $bits
done
run 0 "$RTO" suite sort --radix-bits 4 --sizes 3 --dists random --formats u32 --algos radix -o "$T/srb"
for bits in 0 3 5 7 9 16 four; do
    run 2 "$RTO" sort "$T/k.npy" --algo radix --radix-bits $bits -o "$T/bad" &&
        one_line "rtoracle sort: --radix-bits $bits: expected 4 or 8"
    run 2 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/b/sorted.npy" --radix-bits $bits &&
        one_line "rtoracle check-sort: --radix-bits $bits: expected 4 or 8"
    run 2 "$RTO" suite sort --radix-bits $bits -o "$T/bad" &&
        one_line "rtoracle suite: --radix-bits $bits: expected 4 or 8"
done
# --tile: 1 .. 2^24, in sort, check-sort and suite.
for tile in 1 16777216; do
    run 0 "$RTO" sort "$T/k.npy" --algo radix --tile $tile -o "$T/t$tile"
    run 0 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/b/sorted.npy" --algo radix --tile $tile
done
run 0 "$RTO" suite sort --tile 1 --sizes 3 --dists random --formats u32 --algos radix -o "$T/stile"
for tile in 0 16777217; do
    run 2 "$RTO" sort "$T/k.npy" --algo radix --tile $tile -o "$T/bad" &&
        one_line "rtoracle sort: --tile $tile: expected an integer 1 .. 16777216"
    run 2 "$RTO" check-sort --input "$T/k.npy" --gpu "$T/b/sorted.npy" --tile $tile &&
        one_line "rtoracle check-sort: --tile $tile: expected an integer 1 .. 16777216"
    run 2 "$RTO" suite sort --tile $tile -o "$T/bad" &&
        one_line "rtoracle suite: --tile $tile: expected an integer 1 .. 16777216"
done
# suite --checkpoint-max: 0 .. 2^28 (0: no checkpoints; a 4-key bitonic case then has no passes.npy).
run 0 "$RTO" suite sort --checkpoint-max 0 --sizes 4 --dists random --formats u32 --algos bitonic -o "$T/c0"
[ -e "$T/c0/bitonic-u32-random-n4/passes.npy" ] && fail "--checkpoint-max 0 wrote passes"
run 0 "$RTO" suite sort --checkpoint-max 4 --sizes 4 --dists random --formats u32 --algos bitonic -o "$T/c4"
[ -e "$T/c4/bitonic-u32-random-n4/passes.npy" ] || fail "--checkpoint-max 4 wrote no passes for n = 4"
run 0 "$RTO" suite sort --checkpoint-max 268435456 --sizes 4 --dists random --formats u32 --algos bitonic -o "$T/cmax"
run 2 "$RTO" suite sort --checkpoint-max 268435457 -o "$T/bad" &&
    one_line "rtoracle suite: --checkpoint-max 268435457: expected an integer 0 .. 268435456"
# suite --sizes numbers: 0 .. 2^28, through the same number parser.
run 2 "$RTO" suite sort --sizes 268435457 -o "$T/bad" && has "suite: --sizes 268435457: expected" err
run 2 "$RTO" suite sort --sizes -1 -o "$T/bad" && has "suite: --sizes -1: expected" err
# check-bvh --blas: 0 .. 2^32 - 1 (the parser accepts the top; the bundle's mesh count then refuses it).
run 2 "$RTO" check-bvh --expected "$T/tri" --gpu "$T/tri/tlas_nodes.npy" --blas 4294967296 &&
    one_line "rtoracle check-bvh: --blas 4294967296: expected an integer 0 .. 4294967295"
run 2 "$RTO" check-bvh --expected "$T/tri" --gpu "$T/tri/tlas_nodes.npy" --blas 4294967295 && has "meshes" err
run 0 "$RTO" check-bvh --expected "$T/tri" --gpu "$T/tri/blas_0_nodes.npy" --blas 0 --no-artifacts
# enums name what they accept.
run 2 "$RTO" build triangle --tlas bvh -o "$T/bad" && one_line "rtoracle build: --tlas bvh: expected sweep or karras"
run 2 "$RTO" keys --dist uniform --n 4 --format u16 -o "$T/bad.npy" &&
    one_line "rtoracle keys: --format u16: expected u32 or u64"
run 2 "$RTO" sort "$T/k.npy" --algo quick -o "$T/bad" &&
    one_line "rtoracle sort: --algo quick: expected bitonic or radix"
[ -e "$T/bad" ] || [ -e "$T/bad.npy" ] && fail "a refused command left output behind"

# --- repeated list items make one case each, in the order first given ----------------------------------------------
cases() { grep -o '"case": "[^"]*"' "$1/manifest.json" | sed 's/"case": //; s/"//g' | tr '\n' ' '; }
run 0 "$RTO" suite sort --dists uniform,uniform --sizes 5 --formats u32 --algos bitonic -o "$T/d1" &&
    has "1 cases written" out
[ "$(cases "$T/d1")" = "sort:bitonic:fmt=u32:dist=uniform:n=5 " ] || fail "--dists uniform,uniform: $(cases "$T/d1")"
dirs=$(ls "$T/d1" | grep -c -- -n5)
[ "$dirs" = 1 ] || fail "--dists uniform,uniform wrote $dirs case directories"
run 0 "$RTO" suite sort --dists clustered,random,clustered --sizes 5,05,0x5 --formats u32,u32 --algos bitonic,bitonic \
    -o "$T/d2" && has "2 cases written" out
[ "$(cases "$T/d2")" = "sort:bitonic:fmt=u32:dist=clustered:n=5 sort:bitonic:fmt=u32:dist=random:n=5 " ] ||
    fail "repeated items: $(cases "$T/d2")"
# A group and one of its members: each distribution once, the member where it was first named.
run 0 "$RTO" suite sort --dists line,centroid --sizes 5 --formats u32 --algos radix -o "$T/d3" &&
    has "6 cases written" out
[ "$(cases "$T/d3" | cut -d' ' -f1)" = "sort:radix:fmt=u32:dist=line:n=5" ] || fail "line,centroid: $(cases "$T/d3")"
[ "$(cases "$T/d3" | grep -o 'dist=line' | wc -l)" = 1 ] || fail "line,centroid gave line twice"
run 0 "$RTO" suite sort --dists all,uniform --sizes 5 --formats u64 --algos bitonic -o "$T/d4"
run 0 "$RTO" suite sort --dists all --sizes 5 --formats u64 --algos bitonic -o "$T/d5"
[ "$(cases "$T/d4")" = "$(cases "$T/d5")" ] || fail "--dists all,uniform differs from --dists all"
run 2 "$RTO" suite sort --dists uniform,,line -o "$T/bad" &&
    one_line "rtoracle suite: --dists uniform,,line: empty item in the list"
run 2 "$RTO" suite sort --formats u32,u16 -o "$T/bad" && one_line "rtoracle suite: --formats u16: expected u32 or u64"
run 2 "$RTO" suite sort --dists no-such -o "$T/bad" && has "unknown distribution" err

# --- the command is a user of the public header only ---------------------------------------------------------------
grep -l 'internal\.h' "$SRC"/oracle/* && fail "oracle/ includes a private header of the library"
# --- one home for the box rules (src/core/aabb.c): no other file spells an empty-box test or the empty box ----------
grep -nE 'min\.x (<=|>) [a-z>.-]*max\.x|\{\{INFINITY, INFINITY, INFINITY\}, \{-INFINITY' "$SRC"/src/*/*.c "$SRC"/oracle/*.c |
    grep -v '^[^:]*/core/aabb\.c:' && fail "an empty-box rule outside src/core/aabb.c (above)"

finish "cli opts: all checks passed"

#!/usr/bin/env bash
# Every array check-bvh and check-sort read from a bundle is validated like a GPU dump: a bundle file edited together
# with the manifest's sha256 (so only the arrays themselves can give it away) is refused with status 2 and one line
# naming the file and what is wrong — never read past its end, never trusted. Run under ASan in CI.
set -u
RTO=$1
EDIT=$2
. "$(dirname "$0")/cli_lib.sh"

run 0 "$RTO" build rtstress:5 -o "$T/rs"                # sweep TLAS, 125 instances (n_padded 128)
run 0 "$RTO" build rtstress:3 --tlas karras -o "$T/rk"  # Karras TLAS, 27 instances (n_padded 32)
run 0 "$RTO" keys --dist clustered --n 4097 -o "$T/k32.npy"
run 0 "$RTO" keys --dist random --n 4097 --format u64 -o "$T/k64.npy"
run 0 "$RTO" sort "$T/k32.npy" -o "$T/s32"
run 0 "$RTO" sort "$T/k64.npy" --algo radix -o "$T/s64"

# edited SRC FILE OP... : a fresh copy of bundle SRC in $T/e with FILE edited by bundle_edit (sha256 rewritten)
edited() {
    local src=$1 file=$2
    shift 2
    rm -rf "$T/e" && cp -r "$src" "$T/e" && "$EDIT" "$T/e/$file" "$@" >/dev/null || fail "bundle_edit $file $*"
}
# refused TEXT CMD... : exit 2, exactly one line on stderr, containing TEXT, not a sha256 complaint
refused() {
    local text=$1
    shift
    run 2 "$@" || return
    [ "$(wc -l <"$T/err")" = 1 ] || fail "stderr is not one line: $*"
    has "$text" err
    grep -q sha256 "$T/err" && fail "the edit was caught by sha256, not by the array checks: $(cat "$T/err")"
    return 0
}
tlas() { refused "$1" "$RTO" check-bvh --expected "$T/e" --gpu "$2/tlas_nodes.npy"; }
blas() { refused "$1" "$RTO" check-bvh --expected "$T/e" --blas 0 --gpu "$T/rk/blas_0_nodes.npy"; }

# control: an unedited copy passes, so every refusal below comes from its edit
edited "$T/rs" instances.npy truncate 125
run 0 "$RTO" check-bvh --expected "$T/e" --gpu "$T/rs/tlas_nodes.npy"

# --- the cases of the issue: each crashed (heap overflow under ASan) before the arrays were checked
edited "$T/rk" blas_0_order.npy truncate 1
blas "blas_0_order.npy: holds dtype <u4, shape (1,); expected dtype <u4, shape (12,)"
edited "$T/rk" blas_0_order.npy set-u32 0 0x7fffffff
blas "blas_0_order.npy: entry 0 names triangle 2147483647 of 12"
edited "$T/rk" tlas_sorted_keys.npy truncate 1
tlas "tlas_sorted_keys.npy: holds dtype <u4, shape (1,); expected dtype <u4, shape (32,)" "$T/rk"
edited "$T/rs" instance_aabbs.npy as-u32
tlas "instance_aabbs.npy: holds dtype <u4, shape (750,); expected Aabb records, shape (125,)" "$T/rs"

# --- more: the BLAS leaf order, triangle boxes and nodes
edited "$T/rk" blas_0_order.npy copy-u32 0 1
blas "blas_0_order.npy: triangle .* appears twice (again at entry 1): not a permutation"
edited "$T/rk" blas_0_prim_aabbs.npy truncate 11
blas "blas_0_prim_aabbs.npy: holds Aabb records, shape (11,); expected Aabb records, shape (12,)"
edited "$T/rk" blas_0_prim_aabbs.npy set-f32 0 nan
blas "blas_0_prim_aabbs.npy: box 0 is neither finite with min <= max"
edited "$T/rk" blas_0_nodes.npy truncate 10
blas "blas_0_nodes.npy: holds BlasNode records, shape (10,); expected BlasNode records, shape (11,)"
edited "$T/rk" blas_0_nodes.npy set-u32 3 0x8000000c # node 0's left child: leaf 12 of 12
blas "blas_0_nodes.npy: not a valid tree over the bundle's primitives: bad-link"
edited "$T/rk" blas_0_nodes.npy set-f32 0 -100 # node 0's lmin.x: no longer the union of its child
blas "blas_0_nodes.npy: not a valid tree over the bundle's primitives: box"

# --- instances and their world boxes
edited "$T/rs" instances.npy truncate 3
tlas "instances.npy: holds InstanceRecord records, shape (3,); expected InstanceRecord records, shape (125,)" "$T/rs"
edited "$T/rs" instances.npy set-u32 24 99 # instance 0's blas
tlas "instances.npy: instance 0 names BLAS 99; the bundle has 1 meshes" "$T/rs"
edited "$T/rs" instances.npy set-f32 3 inf # instance 0's objToWorld translation x
tlas "instances.npy: objToWorld of instance 0 is not finite" "$T/rs"
edited "$T/rs" instance_aabbs.npy set-f32 0 nan
tlas "instance_aabbs.npy: box 0 is neither finite with min <= max nor the empty box" "$T/rs"
edited "$T/rs" instance_aabbs.npy set-f32 0 -1000
tlas "instance_aabbs.npy: the box of instance 0 is not the box of BLAS 0 through its objToWorld" "$T/rs"
edited "$T/rs" blas_0_prim_aabbs.npy truncate 1
tlas "blas_0_prim_aabbs.npy: holds Aabb records, shape (1,); expected Aabb records, shape (12,)" "$T/rs"

# --- the TLAS nodes and sorted keys
edited "$T/rs" tlas_nodes.npy truncate 3
tlas "tlas_nodes.npy: holds TlasNode records, shape (3,); expected TlasNode records, shape (255,)" "$T/rs"
edited "$T/rs" tlas_nodes.npy set-u32 1019 0x7fffffff # leaf 0's item (node 127, word 3)
tlas "tlas_nodes.npy: not a valid tree over the bundle's primitives: dropped-leaf" "$T/rs"
edited "$T/rk" tlas_sorted_keys.npy set-u32 31 5
tlas "tlas_sorted_keys.npy: slot 31 holds 0x00000005" "$T/rk"
edited "$T/rk" tlas_sorted_keys.npy set-u32 26 0x80000000
tlas "tlas_sorted_keys.npy: key 26 is 0x80000000: a TLAS key's top bit is 0" "$T/rk"
edited "$T/rk" tlas_sorted_keys.npy copy-u32 1 0
tlas "tlas_sorted_keys.npy: key 1 (0x[0-9a-f]*) does not ascend from key 0" "$T/rk"
edited "$T/rk" tlas_sorted_keys.npy copy-u32 0 0
k0=$("$EDIT" "$T/e/tlas_sorted_keys.npy" copy-u32 0 0) # key 0, unchanged
edited "$T/rk" tlas_sorted_keys.npy set-u32 26 $((0x7fff0000 | (k0 & 0xffff))) # the last key names key 0's instance
tlas "tlas_sorted_keys.npy: key 26 (0x7fff[0-9a-f]*) names instance $((k0 & 0xffff)) a second time" "$T/rk"

# --- the manifest's counts must agree with the arrays
cp -r "$T/rs" "$T/m" && sed -i 's/"n_padded": 128/"n_padded": 256/' "$T/m/manifest.json"
refused "manifest.json: tlas.n_padded is 256; 125 instances have a leaf" "$RTO" check-bvh --expected "$T/m" \
    --gpu "$T/rs/tlas_nodes.npy"
rm -rf "$T/m" && cp -r "$T/rs" "$T/m" && sed -i '0,/"instances": 125/s//"instances": 126/' "$T/m/manifest.json"
refused "instances.npy: holds InstanceRecord records, shape (125,); expected InstanceRecord records, shape (126,)" \
    "$RTO" check-bvh --expected "$T/m" --gpu "$T/rs/tlas_nodes.npy"
rm -rf "$T/m" && cp -r "$T/rs" "$T/m" && sed -i 's/"nodes": 255/"nodes": 253/' "$T/m/manifest.json"
refused "manifest.json: tlas.nodes is 253; a sweep TLAS over 125 leaves has 255" "$RTO" check-bvh --expected "$T/m" \
    --gpu "$T/rs/tlas_nodes.npy"

# --- a manifest that contradicts itself is refused when the bundle is opened, whichever command reads it
# manifest SRC PYTHON: a copy of bundle SRC in $T/m whose manifest.json (as m) is edited by the Python statement
manifest() {
    rm -rf "$T/m" && cp -r "$1" "$T/m" && python3 -c "
import json, sys
p = sys.argv[1]
m = json.load(open(p))
$2
json.dump(m, open(p, 'w'))" "$T/m/manifest.json" || fail "manifest edit: $2"
}
manifest "$T/rk" "m['counts']['meshes'] = 5"
refused "manifest.json: counts.meshes is 5, but no blas_1_ file is listed" "$RTO" check-bvh --expected "$T/m" \
    --gpu "$T/rk/tlas_nodes.npy"
manifest "$T/rk" "m['counts']['meshes'] = 0"
refused "manifest.json: counts.meshes is 0, but the bundle lists blas_0_" "$RTO" check-bvh --expected "$T/m" \
    --gpu "$T/rk/tlas_nodes.npy"
manifest "$T/rk" "m['files'][0]['name'] = '../../../etc/passwd'"
refused "manifest.json: files entry 0 names '../../../etc/passwd', not a plain file name inside the bundle" \
    "$RTO" check-bvh --expected "$T/m" --gpu "$T/rk/tlas_nodes.npy"
manifest "$T/rk" "m['files'][0]['name'] = 'tlas_nodes.npy\\u0000x'"
refused "is not allowed" "$RTO" check-bvh --expected "$T/m" --gpu "$T/rk/tlas_nodes.npy"
run 0 "$RTO" trace rtstress:2 --count 64 --rays random -o "$T/tr"
for shape in "[2**62]" "[1 << 20]"; do
    manifest "$T/tr" "[f.update(shape=$shape) for f in m['files'] if f['name'] == 'rays.npy']"
    refused "manifest.json: the shape of rays.npy has more elements than the file has bytes" \
        "$RTO" check-hits --expected "$T/m" --gpu "$T/tr/hits.npy"
done
for shape in "[2**40, 2**40]" "[-1]" "[1.5]" "'64'"; do
    manifest "$T/tr" "[f.update(shape=$shape) for f in m['files'] if f['name'] == 'rays.npy']"
    refused "manifest.json: the shape of rays.npy is not a list of non-negative integers with a product under 2^62" \
        "$RTO" check-hits --expected "$T/m" --gpu "$T/tr/hits.npy"
done
manifest "$T/tr" "m['files'].append(dict(m['files'][-1]))"
refused "manifest.json lists $(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["files"][-1]["name"])' \
    "$T/tr/manifest.json") twice" "$RTO" check-hits --expected "$T/m" --gpu "$T/tr/hits.npy"
manifest "$T/tr" "del m['files']"
refused "manifest.json has no files list" "$RTO" check-hits --expected "$T/m" --gpu "$T/tr/hits.npy"
# control: the untouched manifest rewritten by the same editor passes
manifest "$T/tr" "pass"
run 0 "$RTO" check-hits --expected "$T/m" --gpu "$T/tr/hits.npy"

# --- check-sort: the bundle's input keys against the manifest
edited "$T/s32" keys.npy truncate 1
refused "keys.npy: holds dtype <u4, shape (1,); the manifest says 4097 u32 keys" "$RTO" check-sort --expected "$T/e" \
    --gpu "$T/s32/sorted.npy"
edited "$T/s64" keys.npy as-u32
refused "keys.npy: holds dtype <u4, shape (8194,); the manifest says 4097 u64 keys" "$RTO" check-sort \
    --expected "$T/e" --gpu "$T/s64/sorted.npy"
rm -rf "$T/m" && cp -r "$T/s32" "$T/m" && sed -i 's/"n_padded": 8192/"n_padded": 4096/' "$T/m/manifest.json"
refused "params.n_padded is 4096, not the next power of two of input.n 4097" "$RTO" check-sort --expected "$T/m" \
    --gpu "$T/s32/sorted.npy"
rm -rf "$T/m" && cp -r "$T/s32" "$T/m" && sed -i 's/"passes": 91/"passes": 90/' "$T/m/manifest.json"
refused "params.passes is 90; the bitonic network over 4097 keys has 91" "$RTO" check-sort --expected "$T/m" \
    --gpu "$T/s32/sorted.npy"
rm -rf "$T/m" && cp -r "$T/s32" "$T/m" && sed -i 's/"n": 4097/"n": 4000/' "$T/m/manifest.json"
refused "keys.npy: holds dtype <u4, shape (4097,); the manifest says 4000 u32 keys" "$RTO" check-sort \
    --expected "$T/m" --gpu "$T/s32/sorted.npy"
run 0 "$RTO" check-sort --expected "$T/s32" --gpu "$T/s32/sorted.npy" # control

finish "every edited bundle array refused by name"

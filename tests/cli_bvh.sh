#!/usr/bin/env bash
# Command-line tests of build / check-bvh: bundles for fixtures and procedural scenes, every tree mutation named at
# its node, structure-only checks, refusals with status 2 and no partial output, byte-identical rebuilds.
set -u
RTO=$1
MUT=$2
FIX=$3
EDIT=$4
. "$(dirname "$0")/cli_lib.sh"

for c in build check-bvh; do run 0 "$RTO" $c --help && has usage out; done

# every fixture builds, with both TLAS layouts, and its own trees pass check-bvh
while IFS= read -r -d '' f; do
    name=$(basename "$f")
    run 0 "$RTO" build "$f" -o "$T/b_$name" || continue
    run 0 "$RTO" check-bvh --expected "$T/b_$name" --gpu "$T/b_$name/tlas_nodes.npy"
    run 0 "$RTO" check-bvh --expected "$T/b_$name" --gpu "$T/b_$name/blas_0_nodes.npy" --blas 0
    run 0 "$RTO" build "$f" --tlas karras -o "$T/k_$name"
done < <(find "$FIX" \( -name '*.gltf' -o -name '*.glb' \) -print0)

# procedural scenes
run 0 "$RTO" build rtstress:5 -o "$T/rs"
grep -q '"instances": 125' "$T/rs/manifest.json" || fail "rtstress:5 should have 125 instances"
run 0 "$RTO" build rtstress:5 --tlas karras -o "$T/rsk"
run 0 "$RTO" build instances:clustered:4097 -o "$T/ic"
run 0 "$RTO" build triangle -o "$T/tri"

# mutations of the sweep TLAS and of Karras trees (BLAS and Karras TLAS), each named at its node
# (tlas-leaf-box: a leaf box far out, its ancestors not following: named at the leaf, bottom-up; tlas-empty-box: an
# EMPTY leaf with a finite box)
for m in tlas-item:item tlas-drop:dropped-leaf tlas-box:box tlas-swap:swapped-children tlas-leaf-box:box \
    tlas-empty-box:empty; do
    node=$("$MUT" "${m%%:*}" "$T/rs/tlas_nodes.npy" "$T/g.npy") || { fail "bvh_mutate ${m%%:*}"; continue; }
    run 1 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/g.npy" --json --no-artifacts &&
        has "\"fault\": \"${m#*:}\"" out && loc node "$node"
done
# a leaf one ulp out, its ancestors the union of the dump's own children: within the §9 transform bound
"$MUT" tlas-leaf-ulp "$T/rs/tlas_nodes.npy" "$T/g.npy" >/dev/null
run 0 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/g.npy" && has "^  mode         exact" out &&
    has "^  tolerance    leaves within 8\*2^-24\*(|m0\*x|+|m1\*y|+|m2\*z|+|t|)" out
bunny=$(find "$FIX" -name 'bunny.gltf' | head -1)
run 0 "$RTO" build "$bunny" -o "$T/bunny"
for m in karras-item:item karras-drop:dropped-leaf karras-box:box karras-swap:swapped-children karras-cycle:cycle; do
    node=$("$MUT" "${m%%:*}" "$T/bunny/blas_0_nodes.npy" "$T/g.npy") || { fail "bvh_mutate ${m%%:*}"; continue; }
    run 1 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/g.npy" &&
        has "^FAIL ${m#*:}" out && has "^  where        node $node" out
    [ -f "$T/g.npy.check-bvh.json" ] || fail "no report artefact for ${m%%:*}"
    rm -f "$T/g.npy.check-bvh.json"
    node=$("$MUT" "${m%%:*}" "$T/rsk/tlas_nodes.npy" "$T/g.npy") || { fail "bvh_mutate ${m%%:*} (karras TLAS)"; continue; }
    run 1 "$RTO" check-bvh --expected "$T/rsk" --gpu "$T/g.npy" --json --no-artifacts &&
        has "\"fault\": \"${m#*:}\"" out
done
# a differently built but valid tree passes --structure-only and fails the exact comparison
"$MUT" karras-swap "$T/bunny/blas_0_nodes.npy" "$T/g.npy" >/dev/null
run 0 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/g.npy" --structure-only
"$MUT" tlas-swap "$T/rs/tlas_nodes.npy" "$T/g.npy" >/dev/null
run 0 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/g.npy" --structure-only
# --gpu-order: the GPU's own leaf order switches to structure-only, and says so; it must be a permutation
cp "$T/bunny/blas_0_order.npy" "$T/order.npy"
run 0 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/bunny/blas_0_nodes.npy" --gpu-order "$T/order.npy" &&
    has "^  mode         structure-only" out && has "leaf order from --gpu-order, which implies --structure-only" out
run 0 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/bunny/blas_0_nodes.npy" --gpu-order "$T/order.npy" \
    --json && has '"mode": "structure-only"' out
"$EDIT" "$T/order.npy" copy-u32 100 300 >/dev/null # leaf 300 holds leaf 100's triangle; leaf 300's triangle in none
run 1 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/bunny/blas_0_nodes.npy" --gpu-order "$T/order.npy" \
    --json --no-artifacts && has '"fault": "item"' out && loc leaf 300
run 2 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/rs/tlas_nodes.npy" --gpu-order "$T/order.npy" && has "Karras" err
run 2 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/bunny/blas_0_nodes.npy" \
    --gpu-order "$T/bunny/instance_aabbs.npy" && has "uint32" err
# a report that cannot reach stdout is an error, not a verdict
"$RTO" check-bvh --expected "$T/rs" --gpu "$T/rs/tlas_nodes.npy" >/dev/full 2>"$T/err"
[ $? = 2 ] && grep -q "cannot write the report to stdout" "$T/err" || fail "check-bvh to a full stdout: $(cat "$T/err")"
# wrong layout / size
run 2 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/rs/tlas_keys.npy" && has "TlasNode" err
run 2 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/rs/tlas_nodes.npy" --blas 7 && has "meshes" err
run 2 "$RTO" check-bvh --expected "$T/rs" && has "required" err

# a mesh without triangles is an empty BLAS (files of shape (0,)); its instance (node 1) gets no TLAS key or leaf
cat >"$T/empty.gltf" <<'EOF'
{"asset":{"version":"2.0"},"buffers":[{"byteLength":44,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}],
 "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
  {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"},{"bufferView":1,"componentType":5123,"count":0,"type":"SCALAR"}],
 "meshes":[{"name":"tri","primitives":[{"attributes":{"POSITION":0},"indices":1}]},
  {"name":"empty","primitives":[{"attributes":{"POSITION":0},"indices":2}]}],
 "nodes":[{"mesh":0},{"mesh":1,"translation":[40,0,40]},{"mesh":0,"translation":[0,3,0]}],"scenes":[{"nodes":[0,1,2]}],"scene":0}
EOF
for t in sweep karras; do
    run 0 "$RTO" build "$T/empty.gltf" --tlas $t -o "$T/e_$t" || continue
    grep -q '"keyed_instances": 2' "$T/e_$t/manifest.json" || fail "$t: manifest should count 2 keyed instances"
    for f in blas_1_sorted_keys blas_1_order blas_1_nodes blas_1_prim_aabbs; do
        grep -aq "'shape': (0,)" "$T/e_$t/$f.npy" || fail "$t: $f.npy should have shape (0,)"
    done
    grep -aq "'shape': (3,)" "$T/e_$t/instance_aabbs.npy" || fail "$t: every instance keeps its world box"
    # the keys of instances 0 and 2 only, quantised over their own centroids (only y differs: q = (0, 31, 0))
    [ "$(tail -c 8 "$T/e_$t/tlas_keys.npy" | od -An -tx4 | tr -s ' ')" = " 00000000 24920002" ] ||
        fail "$t: tlas_keys.npy should hold 0x00000000 0x24920002"
    cmp -s "$T/e_$t/tlas_keys.npy" "$T/e_$t/tlas_sorted_keys.npy" || fail "$t: two keys already in order, no padding"
    run 0 "$RTO" check-bvh --expected "$T/e_$t" --blas 1 --gpu "$T/e_$t/blas_1_nodes.npy"
    # the TLAS over the keyed instances: the oracle's own passes, in both modes
    run 0 "$RTO" check-bvh --expected "$T/e_$t" --gpu "$T/e_$t/tlas_nodes.npy" --no-artifacts &&
        has "over [23] [a-z]* (1 of .*empty.*, in no leaf)" out
    run 0 "$RTO" check-bvh --expected "$T/e_$t" --gpu "$T/e_$t/tlas_nodes.npy" --structure-only --no-artifacts
    # the manifest's keyed count must agree with the instance boxes
    rm -rf "$T/m" && cp -r "$T/e_$t" "$T/m" &&
        sed -i 's/"keyed_instances": 2/"keyed_instances": 3/' "$T/m/manifest.json"
    run 2 "$RTO" check-bvh --expected "$T/m" --gpu "$T/e_$t/tlas_nodes.npy" &&
        has "manifest.json: tlas.keyed_instances is 3; 2 of the 3 instances have a non-empty box" err
    rm -rf "$T/m" && cp -r "$T/e_$t" "$T/m" && sed -i '/"keyed_instances": 2,/d' "$T/m/manifest.json"
    run 2 "$RTO" check-bvh --expected "$T/m" --gpu "$T/e_$t/tlas_nodes.npy" &&
        has "manifest.json: tlas.keyed_instances is missing; 2 of the 3 instances" err
done
grep -aq "'shape': (3,)" "$T/e_sweep/tlas_nodes.npy" || fail "sweep TLAS over 2 keyed instances has 3 nodes"
grep -aq "'shape': (1,)" "$T/e_karras/tlas_nodes.npy" || fail "Karras TLAS over 2 keyed instances has 1 node"
# a GPU that gives the empty instance (1) a leaf: item, at that leaf. Sweep: leaf node 2 (sorted leaf 1, instance 2;
# its item is word 8 * 2 + 3) takes instance 1.
cp "$T/e_sweep/tlas_nodes.npy" "$T/g.npy"
[ "$("$EDIT" "$T/g.npy" set-u32 19 1)" = 0x00000002 ] || fail "leaf node 2 of the sweep TLAS should hold instance 2"
for mode in "" --structure-only; do
    run 1 "$RTO" check-bvh --expected "$T/e_sweep" --gpu "$T/g.npy" $mode --json --no-artifacts &&
        has '"fault": "item"' out && loc node 2 && loc leaf 1 && loc primitive 1 &&
        has "an instance of an empty BLAS" out
done
# Karras: the GPU's own leaf order names instance 1 for sorted leaf 1 (the oracle's order is 0, 2)
cp "$T/e_karras/tlas_keys.npy" "$T/order.npy" # any (2,) uint32 array, overwritten
"$EDIT" "$T/order.npy" set-u32 0 0 >/dev/null && "$EDIT" "$T/order.npy" set-u32 1 2 >/dev/null
run 0 "$RTO" check-bvh --expected "$T/e_karras" --gpu "$T/e_karras/tlas_nodes.npy" --gpu-order "$T/order.npy" \
    --no-artifacts
"$EDIT" "$T/order.npy" set-u32 1 1 >/dev/null
run 1 "$RTO" check-bvh --expected "$T/e_karras" --gpu "$T/e_karras/tlas_nodes.npy" --gpu-order "$T/order.npy" \
    --json --no-artifacts && has '"fault": "item"' out && loc leaf 1 && loc primitive 1 && loc node 0

# refusals: bad specs and broken files exit 2 with one line and leave nothing behind
for spec in rtstress:0 rtstress:41 instances:random:5 instances:uniform:65537 nonsense.txt "$T/missing.gltf"; do
    run 2 "$RTO" build "$spec" -o "$T/bad" && [ "$(wc -l <"$T/err")" = 1 ] || fail "$spec: stderr not one line"
    [ -e "$T/bad" ] && fail "refused build of $spec left $T/bad"
done
ls "$T" | grep -q '\.tmp\.' && fail "temporary directories left behind"

# determinism: the same scene gives byte-identical bundles
run 0 "$RTO" build "$bunny" -o "$T/bunny2"
diff -r "$T/bunny" "$T/bunny2" >/dev/null || fail "two builds of the bunny differ"
run 0 "$RTO" build rtstress:5 -o "$T/rs2"
diff -r "$T/rs" "$T/rs2" >/dev/null || fail "two builds of rtstress:5 differ"

finish "all build / check-bvh checks passed"

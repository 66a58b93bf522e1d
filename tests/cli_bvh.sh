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

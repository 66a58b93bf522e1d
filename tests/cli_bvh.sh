#!/usr/bin/env bash
# Command-line tests of build / check-bvh: bundles for fixtures and procedural scenes, every tree mutation named at
# its node, structure-only checks, refusals with status 2 and no partial output, byte-identical rebuilds.
set -u
RTO=$1
MUT=$2
FIX=$3
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
for m in tlas-item:item tlas-drop:dropped-leaf tlas-box:box tlas-swap:swapped-children; do
    node=$("$MUT" "${m%%:*}" "$T/rs/tlas_nodes.npy" "$T/g.npy") || { fail "bvh_mutate ${m%%:*}"; continue; }
    run 1 "$RTO" check-bvh --expected "$T/rs" --gpu "$T/g.npy" --json --no-artifacts &&
        has "\"fault\": \"${m#*:}\"" out && has "\"node\": $node," out
done
bunny=$(find "$FIX" -name 'bunny.gltf' | head -1)
run 0 "$RTO" build "$bunny" -o "$T/bunny"
for m in karras-item:item karras-drop:dropped-leaf karras-box:box karras-swap:swapped-children karras-cycle:cycle; do
    node=$("$MUT" "${m%%:*}" "$T/bunny/blas_0_nodes.npy" "$T/g.npy") || { fail "bvh_mutate ${m%%:*}"; continue; }
    run 1 "$RTO" check-bvh --expected "$T/bunny" --blas 0 --gpu "$T/g.npy" &&
        has "FAIL ${m#*:}" out && has "node $node" out
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
done
grep -aq "'shape': (3,)" "$T/e_sweep/tlas_nodes.npy" || fail "sweep TLAS over 2 keyed instances has 3 nodes"
grep -aq "'shape': (1,)" "$T/e_karras/tlas_nodes.npy" || fail "Karras TLAS over 2 keyed instances has 1 node"

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

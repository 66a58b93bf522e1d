#!/usr/bin/env bash
# Command-line tests of info: every fixture loads (exit 0), the broken assimp-testmodels files are refused with
# exactly one stderr line and exit 2, procedural specs and bad specs, --help and usage errors, byte-identical reruns.
set -u
RTO=$1
FIX=${RTO_FIXTURES:-fixtures}
ASSIMP=${RTO_ASSIMP_MODELS:-/usr/share/assimp/models/glTF2}
. "$(dirname "$0")/cli_lib.sh"
# A refusal: exit 2, nothing on stdout, exactly one line on stderr naming the command.
refused() {
    run 2 "$@" || return
    [ -s "$T/out" ] && fail "stdout not empty for a refused scene: $*"
    [ "$(wc -l <"$T/err")" = 1 ] || { fail "want exactly one stderr line: $*"; sed 's/^/    | /' "$T/err"; }
    has "^rtoracle info: " err
}

run 0 "$RTO" info --help && has "usage: rtoracle info SCENE" out && has "rtstress:N" out
run 0 "$RTO" --help && has "info" out
run 2 "$RTO" info
run 2 "$RTO" info triangle extra
run 2 "$RTO" info --frobnicate triangle

# every fixture: exit 0, with counts and a scene that is not empty
n=0
while IFS= read -r f; do
    run 0 "$RTO" info "$f" && has "^instances: " out && has "^bounds: .*min" out
    run 0 "$RTO" info "$f" --json && has '"instances": ' out && has '"triangles_instanced": ' out
    n=$((n + 1))
done < <(find "$FIX" -type f \( -iname '*.gltf' -o -iname '*.glb' \) | sort)
[ "$n" -ge 7 ] || fail "only $n fixtures found under $FIX"

# pinned facts
run 0 "$RTO" info "$FIX/CornellBox-nvpro-glTF/cornellBox.gltf" && has "^instances:  10$" out &&
    has "2 instances" out && has "^cameras:    1$" out && has "names image 0, but the file has 0 images" out
run 0 "$RTO" info "$FIX/Duck/glTF/Duck.gltf" && has "512x512 RGBA8  DuckCM.png" out && has "^warnings:   0$" out
run 0 "$RTO" info "$ASSIMP/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" && has "121496 instanced" out

# the broken assimp-testmodels files: one line each
for f in IndexOutOfRange/IndexOutOfRange.gltf IndexOutOfRange/AllIndicesOutOfRange.gltf \
    BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb RecursiveNodes/RecursiveNodes.gltf MissingBin/BoxTextured.gltf \
    wrongTypes/badArray.gltf wrongTypes/badExtension.gltf wrongTypes/badNumber.gltf wrongTypes/badObject.gltf \
    wrongTypes/badString.gltf wrongTypes/badUint.gltf TestNoRootNode/NoScene.gltf SchemaFailures/sceneWrongType.gltf \
    draco/2CylinderEngine.gltf; do
    refused "$RTO" info "$ASSIMP/$f"
done
refused "$RTO" info "$ASSIMP/RecursiveNodes/RecursiveNodes.gltf" && has "cycle" err
refused "$RTO" info "$ASSIMP/draco/2CylinderEngine.gltf" && has "KHR_draco_mesh_compression" err
run 0 "$RTO" info "$ASSIMP/TestNoRootNode/SceneWithoutNodes.gltf" && has "^instances:  0$" out &&
    has "bounds:     empty" out

# every assimp glTF 2.0 file: exit 0, or exit 2 with one line (never a crash)
while IFS= read -r f; do
    "$RTO" info "$f" >"$T/out" 2>"$T/err"
    rc=$?
    case $rc in
    0) ;;
    2) [ "$(wc -l <"$T/err")" = 1 ] || fail "want one stderr line: $f" ;;
    *) fail "exit $rc: $f" ;;
    esac
done < <(find "$ASSIMP" -type f \( -iname '*.gltf' -o -iname '*.glb' \) | sort)

# procedural scenes and bad specs
run 0 "$RTO" info triangle && has "^instances:  1$" out && has "position (0, 0, 2.5)" out
run 0 "$RTO" info rtstress:3 && has "^instances:  27$" out && has "12 unique" out && has "324 instanced" out
run 0 "$RTO" info instances:clustered:4097 --json && has '"instances": 4097' out
run 0 "$RTO" info instances:uniform:0 && has "^instances:  0$" out
for spec in rtstress:0 rtstress:41 rtstress:abc instances:random:5 instances:uniform:65537 nope.obj "$T/missing.gltf" \
    foo:bar ""; do
    refused "$RTO" info "$spec"
done
refused "$RTO" info instances:random:5 && has "not a centroid distribution" err

# an unusable image module costs the textures (a warning each), never the scene
printf 'not a shared object\n' >"$T/bogus.so"
RTO_IMAGE_MODULE="$T/bogus.so" run 0 "$RTO" info "$FIX/Duck/glTF/Duck.gltf" && has "^textures:   0$" out &&
    has "cannot load $T/bogus.so" out
libm=$(find /lib /usr/lib -name 'libm.so.6' 2>/dev/null | head -1)
[ -n "$libm" ] && RTO_IMAGE_MODULE="$libm" run 0 "$RTO" info "$FIX/Duck/glTF/Duck.gltf" &&
    has "is not a compatible image module" out

# same input, same bytes
"$RTO" info "$FIX/CornellBox-nvpro-glTF/cornellBox.gltf" --json >"$T/a.json"
"$RTO" info "$FIX/CornellBox-nvpro-glTF/cornellBox.gltf" --json >"$T/b.json"
cmp -s "$T/a.json" "$T/b.json" || fail "info --json differs between runs"

finish "cli.scene: all passed"

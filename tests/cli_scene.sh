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

# every fixture: exit 0, with counts and a scene that is not empty, as text and as JSON (under the sanitizers one of
# the two in turn: a textured fixture loads OpenImageIO, most of a second there)
n=0
while IFS= read -r f; do
    n=$((n + 1))
    if [ $((n % $(sampled 2))) = 0 ] || [ $((n % 2)) = 1 ]; then
        run 0 "$RTO" info "$f" && has "^instances: " out && has "^bounds: .*min" out
        [ -s "$T/err" ] && { fail "info $f: a successful run wrote to stderr"; sed 's/^/    | /' "$T/err" | head -5; }
    fi
    if [ $((n % $(sampled 2))) = 0 ] || [ $((n % 2)) = 0 ]; then
        run 0 "$RTO" info "$f" --json && has '"instances": ' out && has '"triangles_instanced": ' out
    fi
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

# every assimp glTF 2.0 file: exit 0, or exit 2 with one line (never a crash). Under the sanitizer every other file
# (the suite's fuzz.gltf loads every one of them as a seed there).
k=0
while IFS= read -r f; do
    k=$((k + 1))
    [ $(((k - 1) % $(sampled 2))) = 0 ] || continue
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
run 0 "$RTO" info sphere:2 && has "320 unique" out && has "^vertices:   162$" out
run 0 "$RTO" info sphere:3:7 && has "1280 unique" out && has "icosphere-bumpy" out
run 0 "$RTO" info random:5 --json && has '"cameras"' out
for spec in rtstress:0 rtstress:41 rtstress:abc instances:random:5 instances:uniform:65537 nope.obj "$T/missing.gltf" \
    foo:bar "" sphere:8 sphere:1:x random: random:-1; do
    refused "$RTO" info "$spec"
done
refused "$RTO" info instances:random:5 && has "not a centroid distribution" err

# an unusable image module costs the textures (a warning each), never the scene
printf 'not a shared object\n' >"$T/bogus.so"
RTO_IMAGE_MODULE="$T/bogus.so" run 0 "$RTO" info "$FIX/Duck/glTF/Duck.gltf" && has "^textures:   0$" out &&
    has "cannot load $T/bogus.so" out
libm=$(/sbin/ldconfig -p | awk '$1 == "libm.so.6" { print $NF; exit }')
[ -n "$libm" ] && RTO_IMAGE_MODULE="$libm" run 0 "$RTO" info "$FIX/Duck/glTF/Duck.gltf" &&
    has "is not a compatible image module" out

# A FIFO, a directory, /dev/zero: refused at once (timeout turns a hang into a failure), one line naming the file
# once, exit 2, for info and build alike; build leaves no output behind.
mkfifo "$T/fifo.gltf"
mkdir "$T/dir.gltf"
ln -s /dev/zero "$T/zero.glb"
for f in fifo.gltf dir.gltf zero.glb missing.gltf; do
    refused timeout 20 "$RTO" info "$T/$f"
    [ "$(grep -o "$T/$f" "$T/err" | wc -l)" = 1 ] || fail "info $f: the path is not named exactly once"
    run 2 timeout 20 "$RTO" build "$T/$f" -o "$T/bout" && has "^rtoracle build: $T/$f: " err
    [ "$(wc -l <"$T/err")" = 1 ] || fail "build $f: want one stderr line"
    [ "$(grep -o "$T/$f" "$T/err" | wc -l)" = 1 ] || fail "build $f: the path is not named exactly once"
    [ -e "$T/bout" ] && fail "build $f left $T/bout"
done
refused timeout 20 "$RTO" info "$T/fifo.gltf" && has "not a regular file (a FIFO)" err
refused timeout 20 "$RTO" info "$T/zero.glb" && has "not a regular file (a character device)" err
# ... and as a buffer URI
printf '{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": "fifo.gltf"}]}' >"$T/fifobuf.gltf"
refused timeout 20 "$RTO" info "$T/fifobuf.gltf" && has "buffer 0 ('$T/fifo.gltf'): not a regular file (a FIFO)" err
# A URI that decodes to a name with a NUL byte is named as written (the decoded name would end at the NUL).
printf '{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": "a%%00b.bin"}]}' >"$T/nulbuf.gltf"
refused "$RTO" info "$T/nulbuf.gltf" && has ": buffer 0: URI 'a%00b.bin' decodes to a name with a NUL byte$" err
printf '{"asset": {"version": "2.0"}, "images": [{"uri": "%%00.png"}], "textures": [{"source": 0}],
 "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]}' >"$T/nulimg.gltf"
refused "$RTO" info "$T/nulimg.gltf" && has ": image 0: URI '%00.png' decodes to a name with a NUL byte$" err

# glTF 1.0 (Debian's assimp-testmodels keeps some next to glTF2/)
while IFS= read -r f; do
    refused "$RTO" info "$f" && has "glTF 1.0 is not supported" err
done < <(find "$ASSIMP/../glTF" -type f \( -iname '*.gltf' -o -iname '*.glb' \) | sort)

# A mesh without triangles (a count-0 accessor) is an empty BLAS: info accepts it.
tri36=AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA
printf '{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,%s"}],
 "bufferViews": [{"buffer": 0, "byteLength": 36}], "accessors": [{"bufferView": 0, "componentType": 5126, "count": 0,
 "type": "VEC3"}, {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}], "meshes": [{"primitives":
 [{"attributes": {"POSITION": 0}}]}, {"primitives": [{"attributes": {"POSITION": 1}}]}], "nodes": [{"mesh": 0},
 {"mesh": 1}]}' "$tri36" >"$T/empty.gltf"
run 0 "$RTO" info "$T/empty.gltf" && has "^triangles:  1 unique" out && has "no triangles (an empty BLAS)" out
run 0 "$RTO" info "$T/empty.gltf" --json && has '"triangles": 0' out
run 0 "$RTO" build "$T/empty.gltf" -o "$T/emptyb"
# Finite positions whose world bounds overflow: info and build refuse them alike, naming the node and the mesh.
sed 's/"nodes": \[{"mesh": 0},/"nodes": [{"name": "big", "mesh": 1, "scale": [3e38, 3e38, 3e38]},/' "$T/empty.gltf" \
    >"$T/overflow.gltf"
refused "$RTO" info "$T/overflow.gltf" && has "node 0 ('big'), mesh 1 (''): world bounds" err
run 2 "$RTO" build "$T/overflow.gltf" -o "$T/ovb" && has "node 0 ('big'), mesh 1 (''): world bounds" err

# A corrupt PNG costs its material the texture, with a warning on stdout; the run is silent on stderr (libpng's own
# handlers would print "libpng error: ..."). The PNG: 1x1 RGBA, stored deflate, an invalid filter type (7).
python3 - "$T/badpng.gltf" "$tri36" <<'PY'
import base64, struct, sys, zlib
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
raw = bytes([7, 1, 2, 3, 4])
png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 1, 1, 8, 6, 0, 0, 0))
       + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
open(sys.argv[1], "w").write('{"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": '
    '"data:application/octet-stream;base64,%s"}], "bufferViews": [{"buffer": 0, "byteLength": 36}], "accessors": '
    '[{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}], "images": [{"uri": '
    '"data:image/png;base64,%s"}], "textures": [{"source": 0}], "materials": [{"pbrMetallicRoughness": '
    '{"baseColorTexture": {"index": 0}}}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, '
    '"material": 0}]}], "nodes": [{"mesh": 0}]}' % (sys.argv[2], base64.b64encode(png).decode()))
PY
run 0 "$RTO" info "$T/badpng.gltf" && has "cannot decode: PNG read error: bad adaptive filter value" out
[ -s "$T/err" ] && { fail "info badpng.gltf: a successful run wrote to stderr"; sed 's/^/    | /' "$T/err"; }

# --texture-budget MB: Duck's one 512x512 texture takes exactly 1 MiB; WaterBottle's 2048x2048 base colour 16 MiB
run 0 "$RTO" info "$FIX/Duck/glTF/Duck.gltf" --texture-budget 1 && has "^textures:   1$" out
run 0 "$RTO" info "$FIX/WaterBottle/glTF/WaterBottle.gltf" --texture-budget 16 && has "^textures:   1$" out
refused "$RTO" info "$FIX/WaterBottle/glTF/WaterBottle.gltf" --texture-budget 15 &&
    has "over the texture budget of 15 MiB (raise it with --texture-budget MB)" err
for bad in 0 -1 x 1048577 ""; do
    refused "$RTO" info "$FIX/Duck/glTF/Duck.gltf" --texture-budget "$bad"
done
run 0 "$RTO" build "$FIX/Duck/glTF/Duck.gltf" --texture-budget 1 -o "$T/duck"
run 2 "$RTO" build "$FIX/WaterBottle/glTF/WaterBottle.gltf" --texture-budget 15 -o "$T/wb" &&
    has "^rtoracle build: $FIX/WaterBottle/glTF/WaterBottle.gltf: image 0 " err
[ -e "$T/wb" ] && fail "a refused build left $T/wb"

# same input, same bytes
"$RTO" info "$FIX/CornellBox-nvpro-glTF/cornellBox.gltf" --json >"$T/a.json"
"$RTO" info "$FIX/CornellBox-nvpro-glTF/cornellBox.gltf" --json >"$T/b.json"
cmp -s "$T/a.json" "$T/b.json" || fail "info --json differs between runs"

# A glTF without meshes: described (no mesh, no instance), also as JSON, without touching memory it does not own
# (the sanitizer build caught a write past a one-byte buffer here).
echo '{"asset":{"version":"2.0"}}' >"$T/empty.gltf"
run 0 "$RTO" info "$T/empty.gltf" --json && has '"meshes": \[\]' out
run 0 "$RTO" info "$T/empty.gltf"

finish "cli.scene: all passed"

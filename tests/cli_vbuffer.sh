#!/usr/bin/env bash
# Command-line tests of vbuffer and check-vbuffer. vbuffer: the bundle's files and manifest, the same bytes with 1 and
# 2 threads, bad options and scenes refused with one line; --crosscheck (the rasterizer beside the tracer: every
# sample's closest hit in its admissible set, or explained) on every fixture, rtstress:8, sphere:3, seeded random
# scenes and a camera inside a scene (near-plane clipping), at 1x and 4x MSAA. check-vbuffer: a bundle's own planes
# pass in every dump shape a harness may write (uint32 words, flat arrays, binary16 as bit patterns, depth as
# depth24plus stores it, no material pass); each mutation (vb_mutate) is named with its fault class where it was made;
# a tampered bundle, a mistyped or missing dump plane is refused with status 2 and one line.
set -u
RTO=$1
MUT=$2
FIX=$3
EDIT=$4
TOON=$5     # examples/plugin/toon.c: a material plugin
DEPTH=$6    # examples/plugin/depth.c: a program plugin, not a material one
. "$(dirname "$0")/cli_lib.sh"

run 0 "$RTO" vbuffer --help && has "usage: rtoracle vbuffer SCENE" out && has "vb_visibility.npy" out
run 0 "$RTO" check-vbuffer --help && has "usage: rtoracle check-vbuffer" out && has "coverage, id, barycentric" out
run 0 "$RTO" --help && has "check-vbuffer" out && has "vbuffer" out

# bad usage and input: one line, exit 2, nothing written
for args in "rtstress:2" "rtstress:2 --msaa 2 -o $T/x" "rtstress:2 --width 0 -o $T/x" "rtstress:2 --sun 0,0,0 -o $T/x" \
    "rtstress:2 --sun 1,2 -o $T/x" "rtstress:2 --material toon -o $T/x" "rtstress:2 --width 16384 --height 16384 -o $T/x" \
    "$T/missing.gltf -o $T/x" "rtstress:99 -o $T/x" "rtstress:2 --camera 0,0,0,0,0,0,0,1,0,60 -o $T/x"; do
    run 2 "$RTO" vbuffer $args || continue
    [ "$(wc -l <"$T/err")" = 1 ] || fail "vbuffer $args: want one stderr line: $(cat "$T/err")"
    [ -e "$T/x" ] && fail "vbuffer $args left $T/x"
done

# a bundle: files, manifest, the same bytes with 1 and 2 threads
run 0 "$RTO" vbuffer rtstress:2 --width 64 --height 48 --material lambert --threads 1 -o "$T/rs" &&
    has "^vbuffer rtstress:2: 64x48 x4 samples" out
for f in vb_camera.npy vb_visibility.npy vb_barycentric.npy vb_normal.npy vb_derivatives.npy vb_depth.npy \
    vb_depth_unorm24.npy vb_admissible_offsets.npy vb_admissible.npy vb_edge_mask.npy vb_image.npy \
    vb_base_colors.npy image.png instances.npy mesh_0_positions.npy manifest.json; do
    [ -f "$T/rs/$f" ] || fail "the bundle lacks $f"
done
grep -q '"material": "lambert"' "$T/rs/manifest.json" && grep -q '"sets_of_1": ' "$T/rs/manifest.json" ||
    fail "manifest: no vbuffer.material or admissible statistics"
run 0 "$RTO" vbuffer rtstress:2 --width 64 --height 48 --material lambert --threads 2 -o "$T/rs2"
diff -r "$T/rs" "$T/rs2" >/dev/null || fail "vbuffer: the bundle differs between 1 and 2 threads"

# the rasterizer beside the tracer: 0 unexplained samples, at 1x and 4x (under the sanitizers a sample of scenes)
k=0
for s in "$FIX"/*/glTF/*.gltf "$FIX"/CornellBox-nvpro-glTF/cornellBox.gltf "$FIX"/StanfordBunny/bunny.gltf \
    rtstress:8 sphere:3 triangle random:1 random:2 random:3 random:4; do
    for msaa in 1 4; do
        k=$((k + 1))
        [ $(((k - 1) % $(sampled 4))) = 0 ] || continue
        run 0 "$RTO" vbuffer "$s" --width 80 --height 60 --msaa $msaa --crosscheck -o "$T/cx" &&
            has " 0 unexplained" out
    done
done
# a camera inside rtstress:4 with a wide field of view: triangles cross the near plane
run 0 "$RTO" vbuffer rtstress:4 --camera 0.1,0.2,0.3,5,1,2,0,1,0,90 --width 80 --height 60 --crosscheck -o "$T/cx" &&
    has " 0 unexplained" out && grep -q '"clipped_triangles": [1-9]' "$T/cx/manifest.json" ||
    fail "no clipped triangle inside rtstress:4"

# check-vbuffer: the bundle's own planes pass, in every shape a harness may dump them
B=$T/rs
for m in copy u32 flat bits unorm24; do
    rm -rf "$T/g"
    "$MUT" $m "$B" "$T/g" >/dev/null || fail "vb_mutate $m"
    run 0 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" && has "^PASS ok: " out || fail "control $m"
done
[ -f "$T/g/check-vbuffer.json" ] && fail "a passing check wrote a report"
rm -rf "$T/g"
"$MUT" no-mask "$B" "$T/g" >/dev/null
run 0 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" --json && has '"edge-mask": null' out

# the committed vbuffer goldens, as a harness loads them: their own planes pass
for g in "$FIX"/golden/vbuffer-*; do
    rm -rf "$T/g"
    "$MUT" copy "$g" "$T/g" >/dev/null || fail "vb_mutate copy $g"
    run 0 "$RTO" check-vbuffer --expected "$g" --gpu "$T/g" --no-artifacts || fail "golden $g"
done

# each mutation named with its class where it was made (JSON location; the report written next to the dump)
for m in coverage:coverage id:id instance:id bary:barycentric normal-sign:normal deriv:derivative depth:depth \
    depth-step:depth mask:edge-mask image:shading; do
    rm -rf "$T/g"
    w=$("$MUT" "${m%%:*}" "$B" "$T/g") || { fail "vb_mutate ${m%%:*}"; continue; }
    run 1 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" --json || continue
    has "\"fault\": \"${m#*:}\"" out
    for kv in $w; do
        [ "${m%%:*}" = depth-step ] || loc "${kv%%=*}" "${kv#*=}"
    done
    [ -f "$T/g/check-vbuffer.json" ] || fail "no report written for ${m%%:*}"
done
run 1 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" && has "^FAIL shading: " out

# bad input: exit 2, one line
rm -rf "$T/g" && "$MUT" copy "$B" "$T/g" >/dev/null
cp -r "$B" "$T/tampered"
"$EDIT" "$T/tampered/vb_barycentric.npy" set-u32 5 0x3c003c00 >/dev/null
run 2 "$RTO" check-vbuffer --expected "$T/tampered" --gpu "$T/g" && has "not what this rtoracle computes" err
rm -rf "$T/tampered" && cp -r "$B" "$T/tampered"
"$EDIT" "$T/tampered/vb_visibility.npy" set-u32 0 0x00000007 >/dev/null
run 2 "$RTO" check-vbuffer --expected "$T/tampered" --gpu "$T/g"
"$EDIT" "$T/g/vb_depth.npy" truncate 5 >/dev/null
run 2 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" && has "vb_depth.npy: expected" err
rm -f "$T/g/vb_visibility.npy"
run 2 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" && has "no vb_visibility.npy" err
rm -rf "$T/g2" && "$MUT" transposed "$B" "$T/g2" >/dev/null
run 2 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g2" && has "vb_visibility.npy: expected" err
rm -rf "$T/g2" && "$MUT" copy "$B" "$T/g2" >/dev/null && "$EDIT" "$T/g2/vb_edge_mask.npy" set-u32 0 0x07070707 >/dev/null
run 2 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g2" && has "the mask is 0 or 1" err
run 2 "$RTO" check-vbuffer --expected "$B" --gpu "$T/missing-dir" && has "no such directory" err
mkfifo "$T/g/vb_visibility.npy"
run 2 timeout 20 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g"
run 2 "$RTO" check-vbuffer --expected "$T/missing" --gpu "$T/g"
run 2 "$RTO" check-vbuffer --expected "$B"
for f in "$T"/err; do [ "$(wc -l <"$f")" -le 1 ] || fail "more than one stderr line: $(cat "$f")"; done

# unlit on a textured fixture: the bundle holds the UVs, the mesh's texture and its mip chain; its own planes pass,
# and a changed textured pixel fails as shading (outside the hull of the texels a GPU's filtering may read)
run 0 "$RTO" vbuffer "$FIX/Duck/glTF/Duck.gltf" --width 64 --height 48 --material unlit -o "$T/duck"
for f in mesh_0_uvs.npy vb_mesh_textures.npy vb_textures.npy vb_texture_0.npy; do
    [ -f "$T/duck/$f" ] || fail "the unlit Duck bundle lacks $f"
done
rm -rf "$T/g" && "$MUT" copy "$T/duck" "$T/g" >/dev/null
run 0 "$RTO" check-vbuffer --expected "$T/duck" --gpu "$T/g" && has "^PASS ok: " out
rm -rf "$T/g" && w=$("$MUT" image "$T/duck" "$T/g")
run 1 "$RTO" check-vbuffer --expected "$T/duck" --gpu "$T/g" --json && has '"fault": "shading"' out &&
    has "the texels a GPU's trilinear filtering may read" out

# a material plugin: the bundle records it by name, check-vbuffer shades the GPU's planes with it and needs it
run 0 "$RTO" vbuffer rtstress:2 --width 48 --height 32 --material "$TOON" -o "$T/toon" &&
    grep -q '"material_plugin": "toon"' "$T/toon/manifest.json" || fail "no material_plugin in the manifest"
rm -rf "$T/g" && "$MUT" copy "$T/toon" "$T/g" >/dev/null
run 0 "$RTO" check-vbuffer --expected "$T/toon" --gpu "$T/g" --material "$TOON" && has "^PASS ok: " out
rm -rf "$T/g" && w=$("$MUT" image "$T/toon" "$T/g")
run 1 "$RTO" check-vbuffer --expected "$T/toon" --gpu "$T/g" --material "$TOON" --json && has '"fault": "shading"' out
run 2 "$RTO" check-vbuffer --expected "$T/toon" --gpu "$T/g" && has "material plugin 'toon': pass it" err
run 2 "$RTO" check-vbuffer --expected "$T/toon" --gpu "$T/g" --material "$DEPTH" && has "no rto_material_entry_v1" err
run 2 "$RTO" check-vbuffer --expected "$B" --gpu "$T/g" --material "$TOON" && has "the built-in" err
run 2 "$RTO" vbuffer rtstress:2 --material "$DEPTH" -o "$T/x" && [ ! -e "$T/x" ] || fail "a bad plugin left output"
run 2 "$RTO" vbuffer rtstress:2 --material toon -o "$T/x"

finish "vbuffer and check-vbuffer: bundles, the tracer beside the rasterizer, controls, mutations, a material plugin and bad input"

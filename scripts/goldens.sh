#!/usr/bin/env bash
# Writes the committed golden bundles (fixtures/golden/) into OUTDIR with the given rtoracle binary:
#   bash scripts/goldens.sh RTORACLE OUTDIR
# One line per bundle below; later stages append theirs. Paths are relative to the repository root (the manifests
# record them), so run this from the root. Used by scripts/update-goldens.sh (on purpose) and tests/golden.sh (CI).
set -euo pipefail
. "$(dirname "$0")/deps.sh" # rto_render_settings
rto=$1
out=$2
mkdir -p "$out"
# Sort: every centroid distribution at a small, a checkpointed tile-crossing size and a larger one, bitonic and radix (u32),
# and the u64 format at one size.
"$rto" suite sort --dists centroid --sizes 3,257,4097 --formats u32 --algos bitonic,radix \
    --checkpoint-max 512 -o "$out/sort-u32" >/dev/null
"$rto" suite sort --dists centroid --sizes 257 --formats u64 --algos bitonic --checkpoint-max 512 \
    -o "$out/sort-u64" >/dev/null
# Builds: the procedural scenes, both TLAS layouts, and the small and large fixture scenes.
"$rto" build triangle -o "$out/build-triangle" 2>/dev/null
"$rto" build rtstress:2 -o "$out/build-rtstress-2" 2>/dev/null
"$rto" build rtstress:2 --tlas karras -o "$out/build-rtstress-2-karras" 2>/dev/null
"$rto" build fixtures/Box/glTF/Box.gltf -o "$out/build-Box" 2>/dev/null
"$rto" build fixtures/SimpleMeshes/glTF/SimpleMeshes.gltf -o "$out/build-SimpleMeshes" 2>/dev/null
"$rto" build fixtures/StanfordBunny/bunny.gltf -o "$out/build-bunny" 2>/dev/null
# Traces: primary rays at 64x48 (with the camera block) and random rays, through the Box fixture and rtstress:2.
"$rto" trace fixtures/Box/glTF/Box.gltf --rays primary --width 64 --height 48 -o "$out/trace-Box" 2>/dev/null
"$rto" trace rtstress:2 --rays primary --width 64 --height 48 -o "$out/trace-rtstress-2" 2>/dev/null
"$rto" trace rtstress:2 --rays random --count 1024 -o "$out/trace-rtstress-2-random" 2>/dev/null
# Frames. Every per-bounce buffer of sun-shadow's two bounces on the Box fixture and on rtstress:2 (--stages all);
# the other frames are lean goldens (render's default: accum buffer, image and counters), so the repository stays
# small: the Box with triangle and normals, the triangle scene, sun-shadow on the textured Duck and on the Cornell box
# (its sun from fixtures/render-settings.txt; both at their cameras' aspect), and seed 002's stage2 scene at its 160x120.
"$rto" render fixtures/Box/glTF/Box.gltf --program sun-shadow --width 96 --height 54 --stages all \
    -o "$out/frame-Box-sun-shadow" >/dev/null
"$rto" render rtstress:2 --program sun-shadow --width 64 --height 48 --stages all -o "$out/frame-rtstress-2" >/dev/null
for prog in triangle normals; do
    "$rto" render fixtures/Box/glTF/Box.gltf --program $prog --width 160 --height 90 -o "$out/frame-Box-$prog" >/dev/null
done
"$rto" render triangle --program triangle --width 160 --height 90 -o "$out/frame-triangle" >/dev/null
"$rto" render fixtures/Duck/glTF/Duck.gltf --program sun-shadow --width 150 --height 100 -o "$out/frame-Duck" >/dev/null
cornell=fixtures/CornellBox-nvpro-glTF/cornellBox.gltf
mapfile -t settings < <(rto_render_settings $cornell sun-shadow)
"$rto" render $cornell --program sun-shadow --width 160 --height 120 "${settings[@]}" -o "$out/frame-CornellBox" \
    >/dev/null 2>&1
"$rto" render stage2 --program normals --width 160 --height 120 -o "$out/frame-stage2" >/dev/null
# Visibility buffers: rtstress:2 at 4x MSAA with the lambert material, the Box fixture at 1x with normals.
"$rto" vbuffer rtstress:2 --width 32 --height 24 --material lambert -o "$out/vbuffer-rtstress-2" >/dev/null
"$rto" vbuffer fixtures/Box/glTF/Box.gltf --width 32 --height 24 --msaa 1 -o "$out/vbuffer-Box" >/dev/null
# Fluid (seed 003): a splash splatted at 24^3 with its occupancy grid, and raymarched at 32x24 with and without skipping.
"$rto" splat splash:1000 --resolution 24 --radius 0.12 -o "$out/fluid-splat-splash" >/dev/null
"$rto" raymarch "$out/fluid-splat-splash" --width 32 --height 24 -o "$out/fluid-raymarch-splash" >/dev/null

#!/usr/bin/env bash
# The main job: install what is missing, build everything, and write the golden bundles to out/goldens/.
#   bash scripts/main.sh [--full] [extra arguments for `rtoracle suite sort`]
# By default the lean goldens (under 200 MB): the sort matrix's tiny and tile size classes (every n a tile boundary
# makes interesting, up to 4,097), traces at 128x96, frames as lean goldens (image, accum, counters) and visibility
# buffers at 128x96. --full: every size class up to 65,536 keys, traces and visibility buffers at 320x240 and every
# frame's per-bounce queues, hits and payloads too.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/deps.sh
trap 'rto_say "scripts/main.sh: line $LINENO failed: $BASH_COMMAND"' ERR
full=0
if [ "${1:-}" = --full ]; then
    full=1
    shift
fi
rto_install_deps
rto_install_gpu_deps
rto_build build --werror
rto=build/oracle/rtoracle
out=out/goldens
mkdir -p "$out"
# What each command prints (a summary or "up to date" line per bundle, loader warnings) goes to temporary files
# outside out/: a run that changes nothing writes nothing there. A failure shows them and stops.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Every command below leaves a bundle that is already up to date alone (same inputs, options and rtoracle build, no
# file changed since; README "Re-running the main job"), so a second run rewrites nothing.
# golden FAMILY RTORACLE-ARGS...: one bundle of a family; its output kept for the family's summary line.
declare -A bundles=()
golden() {
    local family=$1
    shift
    bundles[$family]=$((${bundles[$family]:-0} + 1))
    "$rto" "$@" >>"$tmp/$family.out" 2>"$tmp/err" ||
        { cat "$tmp/$family.out" "$tmp/err" >&2; rto_say "rtoracle $* failed"; exit 1; }
}
# family_done FAMILY DIR [WHAT]: one line per family: what it holds (default: its bundles), how many bundles were
# up to date, its size on disk, the time it took.
t_family=$SECONDS
family_done() {
    local n=${bundles[$1]} fresh size
    fresh=$(grep -c 'is up to date' "$tmp/$1.out" 2>/dev/null) || true
    size=$(du -sh "$2" | cut -f1)
    rto_say "goldens: $1: ${3:-$n bundles} ($((n - fresh)) written, $fresh up to date), ${size}B in $2" \
        "($((SECONDS - t_family)) s)"
    t_family=$SECONDS
}
fixture_scenes() { find fixtures \( -name '*.gltf' -o -name '*.glb' \) | sort; }

# The sort matrix a GPU harness runs: every distribution x format x algorithm at the sizes of the tiny and tile
# classes, checkpoints up to 256 keys (with --full every size class, checkpoints up to 1,024) in one bundle.
if [ $full = 1 ]; then
    sort_args=(--sizes all)
    rto_say "goldens: sort: the whole matrix into $out/sort (4,324 cases, 413 MB on disk when written)"
else
    sort_args=(--sizes tiny,tile --checkpoint-max 256)
    rto_say "goldens: sort: the matrix up to 4,097 keys into $out/sort (1,472 cases, 52 MB on disk when written;" \
        "scripts/main.sh --full for every size class)"
fi
golden sort suite sort "${sort_args[@]}" -o "$out/sort" "$@"
family_done sort "$out/sort" "$(grep -c '"case"' "$out/sort/manifest.json") cases in 1 bundle"

# Acceleration-structure bundles of every bundled fixture scene and the procedural scenes.
mkdir -p "$out/build"
while IFS= read -r f; do
    golden build build "$f" -o "$out/build/$(basename "${f%.*}")"
done < <(fixture_scenes)
for spec in triangle rtstress:16 instances:clustered:4097; do
    golden build build "$spec" -o "$out/build/${spec//:/-}"
done
family_done build "$out/build"

# Trace bundles: primary and shadow rays at 128x96 (with --full 320x240) through every fixture scene and the
# procedural ones (the inputs of a GPU's TRACE kernel and the hit records it must write).
mkdir -p "$out/trace"
size=(--width 128 --height 96)
[ $full = 0 ] || size=(--width 320 --height 240)
while IFS= read -r f; do
    for set in primary shadow; do
        golden trace trace "$f" --rays $set "${size[@]}" -o "$out/trace/$(basename "${f%.*}")-$set"
    done
done < <(fixture_scenes)
for spec in triangle rtstress:16; do
    golden trace trace "$spec" --rays primary "${size[@]}" -o "$out/trace/${spec//:/-}-primary"
done
family_done trace "$out/trace"

# Frame bundles: one wavefront frame per scene with a fitting program, as lean goldens (image, accum buffer, every
# counter and indirect argument a GPU's frame must produce); with --full also every queue, hit and payload.
mkdir -p "$out/frame"
stages=lean
[ $full = 0 ] || stages=all
frame() { golden frame render "$@" --width 320 --height 240 --stages $stages; }
while IFS= read -r f; do
    mapfile -t settings < <(rto_render_settings "$f" sun-shadow)
    frame "$f" --program sun-shadow "${settings[@]}" -o "$out/frame/$(basename "${f%.*}")-sun-shadow"
done < <(fixture_scenes)
frame triangle --program triangle -o "$out/frame/triangle"
frame rtstress:16 --program sun-shadow -o "$out/frame/rtstress-16-sun-shadow"
frame stage2 --program normals -o "$out/frame/stage2"
family_done frame "$out/frame"

# Visibility-buffer bundles (seed 004): the G-buffer per sample of 4x MSAA, each sample's admissible set, the edge mask
# and the lambert image, at 128x96 (with --full 320x240), of every fixture scene and the procedural ones.
mkdir -p "$out/vbuffer"
vsize=(--width 128 --height 96)
[ $full = 0 ] || vsize=(--width 320 --height 240)
while IFS= read -r f; do
    golden vbuffer vbuffer "$f" --material lambert "${vsize[@]}" -o "$out/vbuffer/$(basename "${f%.*}")"
done < <(fixture_scenes)
for spec in triangle rtstress:16; do
    golden vbuffer vbuffer "$spec" --material lambert "${vsize[@]}" -o "$out/vbuffer/${spec//:/-}"
done
family_done vbuffer "$out/vbuffer"

# Fluid bundles (seed 003): each particle generator splatted into a 64^3 volume (with --full the seed's 150^3) with its
# occupancy grid, and raymarched at 160x120 (320x240) with and without empty-space skipping.
mkdir -p "$out/fluid"
fres=64 rsize=(--width 160 --height 120)
[ $full = 0 ] || { fres=150 rsize=(--width 320 --height 240); }
for spec in dambreak:20000 pool:20000 splash:20000 single lattice; do
    name=${spec//:/-}
    golden fluid splat "$spec" --resolution $fres -o "$out/fluid/splat-$name"
    golden fluid raymarch "$out/fluid/splat-$name" "${rsize[@]}" -o "$out/fluid/raymarch-$name"
done
family_done fluid "$out/fluid"
rto_say "built $rto; golden bundles in $out/ ($(du -sh "$out" | cut -f1)B)"

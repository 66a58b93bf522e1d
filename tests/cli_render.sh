#!/usr/bin/env bash
# Command-line tests of render: every built-in program on a fixture, a procedural scene and stage2; the bundle's files
# and manifest; --stages, --param and --no-timings; bytes independent of --threads; the example plugin; refusals
# (exit 2, one line, nothing written) of bad programs, plugins, parameters, sizes and outputs that are not ours.
set -u
RTO=$1
FIX=$2
JSON=$3
PLUGIN=$4
. "$(dirname "$0")/cli_lib.sh"

field() { "$JSON" "$1/manifest.json" "$2"; }

run 0 "$RTO" render --help && has usage out && has "indirect_args.npy" out
run 0 "$RTO" render --program list && has "sun-shadow" out && has "sun_dir" out

box="$FIX/Box/glTF/Box.gltf"
# Under the sanitizer, the scene x program pairs of one parity (5 of 9): every scene and every program still runs.
k=0
for scene in "$box" rtstress:2 stage2; do
    tag=$(basename "$scene" | tr -c 'a-zA-Z0-9\n' _)
    for prog in triangle sun-shadow normals; do
        k=$((k + 1))
        [ $(((k - 1) % $(sampled 2))) = 0 ] || continue
        out="$T/${tag}_$prog"
        run 0 "$RTO" render "$scene" --program $prog --width 40 --height 30 --stages all -o "$out" || continue
        has "render" out
        [ "$(field "$out" kind)" = '"frame"' ] || fail "$tag $prog: kind $(field "$out" kind)"
        [ "$(field "$out" program/name)" = "\"$prog\"" ] || fail "$tag $prog: program.name"
        depth=$(field "$out" frame/max_depth)
        want=1; [ $prog = sun-shadow ] && want=2
        [ "$depth" = $want ] || fail "$tag $prog: max_depth $depth, want $want"
        for f in camera.npy emit_counts.npy indirect_args.npy frame_counters.npy accum.npy not_comparable.npy \
                 bounce_0_rays.npy bounce_0_hits.npy bounce_0_trace_counters.npy "bounce_${want}_rays.npy" \
                 accum.exr image.png; do
            [ -f "$out/$f" ] || fail "$tag $prog: no $f"
        done
        # the first queue holds one primary ray per pixel
        [ "$(field "$out" counters/traced)" -ge 1200 ] || fail "$tag $prog: traced $(field "$out" counters/traced)"
        field "$out" timings >/dev/null 2>&1 && fail "$tag $prog: timings without --timings"
    done
done
[ -f "$T/stage2_normals/blas_0_nodes.npy" ] && fail "stage2: a build file in an analytic scene's bundle"
[ "$(field "$T/stage2_normals" frame/scene_kind)" = '"stage2"' ] || fail "stage2: scene_kind"

# --threads and repeated runs give the same bytes, every buffer kept, with no other flag (wall times only with
# --timings)
for t in 1 2 5 2; do
    rm -rf "$T/t$t"
    run 0 "$RTO" render rtstress:3 --program sun-shadow --width 48 --height 36 --stages all --threads $t -o "$T/t$t"
    [ -d "$T/t1" ] && { diff -r "$T/t1" "$T/t$t" >/dev/null || fail "--threads 1 and $t differ"; }
done
field "$T/t1" timings >/dev/null 2>&1 && fail "timings written without --timings"
run 0 "$RTO" render rtstress:3 --program sun-shadow --width 48 --height 36 --timings -o "$T/timed"
field "$T/timed" timings >/dev/null || fail "--timings wrote no timings"
run 0 "$RTO" render rtstress:3 --program sun-shadow --width 48 --height 36 --stages all --no-timings -o "$T/old"
diff -r "$T/t1" "$T/old" >/dev/null || fail "--no-timings (the default) differs from no flag"
# the default, the lean golden: two runs with no flag at all are the same bytes; it holds the image, accum and
# counters and no per-bounce buffer, and its frame is the full dump's (the same counters, accum and image)
run 0 "$RTO" render rtstress:3 --program sun-shadow --width 48 --height 36 -o "$T/lean1"
run 0 "$RTO" render rtstress:3 --program sun-shadow --width 48 --height 36 -o "$T/lean2"
diff -r "$T/lean1" "$T/lean2" >/dev/null || fail "two renders with no flag differ"
[ "$(field "$T/lean1" frame/stages)" = '"accum"' ] || fail "the default stages: $(field "$T/lean1" frame/stages)"
ls "$T/lean1" | grep -q 'bounce_\|accum.exr' && fail "the lean golden holds $(ls "$T/lean1" | grep 'bounce_\|exr')"
for f in accum.npy image.png frame_counters.npy emit_counts.npy indirect_args.npy not_comparable.npy; do
    cmp -s "$T/lean1/$f" "$T/t1/$f" || fail "the lean golden's $f differs from the full dump's"
done

# --stages none keeps the small files only; --stages rays,accum those two
run 0 "$RTO" render rtstress:2 --program sun-shadow --width 32 --height 24 --stages none -o "$T/none"
ls "$T/none" | grep -q bounce_ && fail "--stages none wrote per-bounce files"
[ -f "$T/none/accum.npy" ] && fail "--stages none wrote accum.npy"
[ "$(field "$T/none" frame/stages)" = '"none"' ] || fail "--stages none: manifest"
run 0 "$RTO" render rtstress:2 --program sun-shadow --width 32 --height 24 --stages rays,accum -o "$T/ra"
[ -f "$T/ra/bounce_1_rays.npy" ] && [ -f "$T/ra/accum.npy" ] && [ ! -f "$T/ra/bounce_0_hits.npy" ] ||
    fail "--stages rays,accum"
[ "$(field "$T/ra" counters/traced)" = "$(field "$T/none" counters/traced)" ] || fail "--stages changed the frame"

# parameters: recorded, and they change the image
run 0 "$RTO" render rtstress:2 --program sun-shadow --width 32 --height 24 --param "sky=1,0,0:ambient=0.5,0.5,0.5" \
    -o "$T/par"
[ "$(field "$T/par" parameters/sky)" = '"1,0,0"' ] || fail "--param sky: $(field "$T/par" parameters/sky)"
[ "$(field "$T/par" parameters/sun_dir)" = '"0.300000012,1,0.200000003"' ] || fail "default sun_dir not recorded"
cmp -s "$T/par/accum.npy" "$T/t1/accum.npy" && fail "--param did not change the accum buffer"
run 2 "$RTO" render rtstress:2 --program sun-shadow --param "nope=1" -o "$T/bad" && has "no parameter 'nope'" err
run 2 "$RTO" render rtstress:2 --program sun-shadow --param "sky=1,2" -o "$T/bad" && has "takes 3 values" err
run 2 "$RTO" render rtstress:2 --program sun-shadow --param "sky=1,x,2" -o "$T/bad" && has "finite numbers" err
run 2 "$RTO" render rtstress:2 --program sun-shadow --param "sun_dir=0,0,0" -o "$T/bad" && has "cannot be normalised" err
[ -e "$T/bad" ] && fail "a refused render left $T/bad"

# the example plugin: loaded, its parameters settable, its init refusal reported
run 0 "$RTO" render rtstress:2 --program "$PLUGIN" --width 32 --height 24 --param range=30 -o "$T/plug" &&
    [ "$(field "$T/plug" program/name)" = '"depth"' ] && [ "$(field "$T/plug" program/kind)" = '"plugin"' ] &&
    case "$(field "$T/plug" parameters/range)" in 30 | 30.0) true ;; *) false ;; esac || fail "plugin render: $(cat "$T/err")"
run 2 "$RTO" render rtstress:2 --program "$PLUGIN" --param range=-1 -o "$T/bad" && has "range must be positive" err
printf 'not an ELF' > "$T/fake.so"
run 2 "$RTO" render rtstress:2 --program "$T/fake.so" -o "$T/bad" && has "cannot load" err
run 2 "$RTO" render rtstress:2 --program "$T/missing.so" -o "$T/bad" && has "No such file" err
mkfifo "$T/fifo.so"
run 2 "$RTO" render rtstress:2 --program "$T/fifo.so" -o "$T/bad" && has "not a regular file" err
run 2 "$RTO" render rtstress:2 --program nosuch -o "$T/bad" && has "not a built-in program" err

# bad sizes, stages, scenes and outputs
run 2 "$RTO" render rtstress:2 --program triangle --width 0 -o "$T/bad"
run 2 "$RTO" render rtstress:2 --program triangle --width 65536 --height 65536 -o "$T/bad" && has "pixels" err
run 2 "$RTO" render rtstress:2 --program triangle --stages rays,bogus -o "$T/bad" && has "unknown stage 'bogus'" err
run 2 "$RTO" render "$T/nope.gltf" --program triangle -o "$T/bad"
run 2 "$RTO" render stage2 --program triangle --camera 3 -o "$T/bad" && has "stage2 takes" err
echo "keep me" > "$T/user.txt"
run 2 "$RTO" render rtstress:2 --program triangle -o "$T/user.txt"
[ "$(cat "$T/user.txt")" = "keep me" ] || fail "a user's file was replaced"
[ "$(wc -l < "$T/err")" = 1 ] || fail "a refusal printed more than one line"
[ -e "$T/bad" ] && fail "a refused render left output"

# Memory: the frame's bound (its queues at capacity, the kept stages) is checked against the budget before the scene
# is loaded: over it, one line with both figures and exit 2 within a second and 300 MB, nothing written.
bounded 2 "render 8192x8192 over the budget" "$RTO" render rtstress:2 --program sun-shadow --width 8192 \
    --height 8192 --stages none --memory-budget 4096 -o "$T/bad" &&
    has "a 8192x8192 frame of sun-shadow (maxDepth 2, --stages none) may hold up to 20.93 GiB at once, over the memory budget of 4.00 GiB (--memory-budget)" err
bounded 2 "render 4096x4096 over the budget" "$RTO" render rtstress:2 --program sun-shadow --width 4096 \
    --height 4096 --stages none --memory-budget 1024 -o "$T/bad" && has "up to 5.32 GiB at once" err
# kept stages count at capacity: all of them at 1024 x 1024 need more than 1 GiB, none of them less
bounded 2 "render 1024x1024, all stages, over the budget" "$RTO" render rtstress:2 --program sun-shadow \
    --width 1024 --height 1024 --stages all --memory-budget 1000 -o "$T/bad" && has "up to 1.00 GiB at once" err
[ -e "$T/bad" ] && fail "a render over its memory budget left output"
# within the budget it runs; and the bound holds: the peak of a frame stays under its bound plus the process's own
# 200 MB (libraries, the scene and its trees; the sanitizer's shadow memory makes the figure meaningless there)
if [ -z "${RTO_TEST_SANITIZED:-}" ]; then
    for c in "1024 1024 none sun-shadow" "1024 1024 all sun-shadow" "1024 512 rays,hits,payloads normals"; do
        set -- $c
        prog=$4
        "$RTO" render rtstress:2 --program "$prog" --width "$1" --height "$2" --stages "$3" --memory-budget 1 \
            -o "$T/bad" 2>"$T/err"
        gib=$(sed -n 's/.* up to \([0-9.]*\) GiB.*/\1/p' "$T/err")
        peak "$RTO" render rtstress:2 --program "$prog" --width "$1" --height "$2" --stages "$3" -o "$T/mem" \
            --memory-budget 2048 >"$T/peak"
        read -r rc kib secs <"$T/peak"
        [ "$rc" = 0 ] && awk -v k="$kib" -v g="$gib" 'BEGIN { exit !(k * 1024 <= g * 2^30 + 200 * 2^20) }' ||
            fail "render $c: exit $rc, peak $kib KiB over its bound of $gib GiB + 200 MiB"
    done
    rm -rf "$T/mem"
    # the default budget: half the address space a process may use (here 4 GB: the 5.32 GiB frame is refused)
    (ulimit -v 4000000 && exec "$RTO" render rtstress:2 --program sun-shadow --width 4096 --height 4096 \
        --stages none -o "$T/bad") >"$T/out" 2>"$T/err"
    [ $? = 2 ] && has "over the memory budget of 1.91 GiB (half the memory this process may use" err
fi

# re-rendering over a previous frame bundle replaces it
run 0 "$RTO" render rtstress:2 --program triangle --width 16 --height 8 -o "$T/plug"
[ "$(field "$T/plug" program/name)" = '"triangle"' ] || fail "a previous bundle was not replaced"

# A scene camera whose aspect is not the image's: a warning that the image is stretched (none when they agree); in
# the optimised build (the command-line check, no new memory use)
cornell="$FIX/CornellBox-nvpro-glTF/cornellBox.gltf"
if [ -z "${RTO_TEST_SANITIZED:-}" ]; then
    run 0 "$RTO" render "$cornell" --program sun-shadow --width 64 --height 36 --stages none -o "$T/wide" &&
        has "warning: camera '.*' has aspect 1.333, the image 64x36 has 1.778: the image is stretched" err
    [ "$(field "$T/wide" camera/aspect_from)" = '"camera"' ] && [ "$(field "$T/wide" camera/aspect)" = 1.3333333730697632 ] ||
        fail "the manifest's camera aspect: $(field "$T/wide" camera/aspect) from $(field "$T/wide" camera/aspect_from)"
    [ "$(field "$T/ra" camera/aspect_from)" = '"image"' ] && [ "$(field "$T/ra" camera/aspect)" = 1.3333333333333333 ] ||
        fail "an auto camera's aspect: $(field "$T/ra" camera/aspect) from $(field "$T/ra" camera/aspect_from)"
    run 0 "$RTO" render "$cornell" --program sun-shadow --width 64 --height 48 --stages none -o "$T/fit" &&
        ! grep -q "stretched" "$T/err" || fail "a warning for a camera of the image's aspect"
fi

finish "cli.render: ok"

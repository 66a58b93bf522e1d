// Case family "frame": the wavefront chain GENERATE -> PREP -> (TRACE -> SHADE -> PREP) x maxDepth -> RESOLVE with
// dispatchWorkgroupsIndirect (DESIGN.md §7) for the built-in triangle and sun-shadow programs. rtoracle render writes
// the frame's bundle (the inputs, and every buffer as the oracle expects it), the GPU renders the frame from the
// bundle's scene, camera and parameters and dumps its buffers, rtoracle check-frame compares them stage by stage.
import {spawnSync} from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {renderFrame, writeFrameDump} from '../lib/frame.js';
import {check, rtoracle} from '../lib/oracle.js';

export const family = 'frame';

const PROGRAMS = ['triangle', 'sun-shadow'];

const frameCase = (program, scene, width = 64, height = 64) => ({family, program, scene, width, height,
  id: `frame/${program}/${scene.includes('/') ? path.basename(scene) : scene}/${width}x${height}`});

/** --scenes: every name must load (rtoracle info), else one line and exit status 2 before any case runs. */
function checkScenes(opts) {
  for (const s of opts.scenes) {
    const r = spawnSync(opts.rtoracle, ['info', s], {encoding: 'utf8'});
    if (r.status !== 0) {
      console.error(`gpu/run: --scenes: ${(r.stderr || r.stdout || String(r.error)).trim().split('\n')[0]}`);
      process.exit(2);
    }
  }
}

/** ci: one frame per program on rtstress:4 at 64x64 (issue 9's acceptance list). full: also the VulkanTriangle scene,
 * an icosphere, a clustered instance set and a 160x90 frame. Only scenes without vertex normals, uvs or materials:
 * a bundle carries positions and indices only (triangle needs no surface and renders any mesh scene). --scenes:
 * both programs on each scene named, 64x64. */
export function list(opts) {
  if (opts.scenes) {
    checkScenes(opts);
    return opts.scenes.flatMap((s) => PROGRAMS.map((p) => frameCase(p, s)));
  }
  const ci = PROGRAMS.map((p) => frameCase(p, 'rtstress:4'));
  if (opts.subset === 'ci') return ci;
  return [...ci, frameCase('triangle', 'triangle'),
    ...['sphere:3', 'instances:clustered:257'].flatMap((s) => PROGRAMS.map((p) => frameCase(p, s))),
    ...PROGRAMS.map((p) => frameCase(p, 'rtstress:4', 160, 90))];
}

export async function run(ctx, c) {
  const expected = path.join(ctx.dir, 'expected');
  rtoracle(ctx.rtoracle, ['render', c.scene, '--program', c.program, '--width', String(c.width), '--height',
    String(c.height), '--no-timings', '-o', expected]);
  const frame = await renderFrame(ctx.device, new Bundle(expected), {timer: ctx.timer});
  writeFrameDump(ctx.dir, frame);
  // Without --no-artifacts: on an accum or image fault check-frame writes its diff images into the dump directory.
  const r = check(ctx.rtoracle, 'check-frame', ['--expected', expected, '--gpu', ctx.dir]);
  const diff = path.join(ctx.dir, 'check-frame.image_diff.png');
  return {...r, check: 'check-frame', images: {expected: path.join(expected, 'image.png'),
    actual: path.join(ctx.dir, 'image.png'), diff: fs.existsSync(diff) ? diff : null}};
}

// Case family "frame": the wavefront chain GENERATE -> PREP -> (TRACE -> SHADE -> PREP) x maxDepth -> RESOLVE with
// dispatchWorkgroupsIndirect (DESIGN.md §7) for the built-in triangle and sun-shadow programs. rtoracle render writes
// the frame's bundle (the inputs, and every buffer as the oracle expects it), the GPU renders the frame from the
// bundle's scene, camera and parameters and dumps its buffers, rtoracle check-frame compares them stage by stage.
import fs from 'node:fs';
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {renderFrame, writeFrameDump} from '../lib/frame.js';
import {check, checkScenes, rtoracle, scenePath} from '../lib/oracle.js';

export const family = 'frame';

const PROGRAMS = ['triangle', 'sun-shadow'];

const frameCase = (program, scene, width = 64, height = 64) => ({family, program, scene, width, height,
  id: `frame/${program}/${scene.includes('/') ? path.basename(scene) : scene}/${width}x${height}`});

/** ci: one frame per program on rtstress:4 at 64x64 (issue 9's acceptance list). full: also the VulkanTriangle scene,
 * an icosphere, a clustered instance set and a 160x90 frame. Only scenes without vertex normals, uvs or materials:
 * a bundle carries positions and indices only (triangle needs no surface and renders any mesh scene). --scenes:
 * both programs on each scene named, 64x64. */
export function list(opts) {
  if (opts.scenes) {
    checkScenes(opts.rtoracle, opts.scenes);
    return opts.scenes.flatMap((s) => PROGRAMS.map((p) => frameCase(p, s)));
  }
  const ci = PROGRAMS.map((p) => frameCase(p, 'rtstress:4'));
  if (opts.subset === 'ci') return ci;
  return [...ci, frameCase('triangle', 'triangle'),
    ...['sphere:3', 'instances:clustered:257'].flatMap((s) => PROGRAMS.map((p) => frameCase(p, s))),
    ...PROGRAMS.map((p) => frameCase(p, 'rtstress:4', 160, 90))];
}

/** The oracle's frame bundle: the GPU's inputs (scene, camera, parameters) and every buffer it must match (--stages
 * all: each bounce's queue, hits and payloads, not only the lean golden's image, accum and counters). */
export function prepare(ctx, c) {
  rtoracle(ctx.rtoracle, ['render', scenePath(c.scene), '--program', c.program, '--width', String(c.width),
    '--height', String(c.height), '--stages', 'all', '-o', path.join(ctx.dir, 'expected')]);
}

/** The GPU's frame, rendered from the bundle's inputs alone, dumped under the bundle's file names. */
export async function dump(ctx) {
  const frame = await renderFrame(ctx.device, new Bundle(path.join(ctx.dir, 'expected')), {timer: ctx.timer});
  writeFrameDump(ctx.dumpDir, frame);
}

export function validate(ctx) {
  const expected = path.join(ctx.dir, 'expected');
  // Without --no-artifacts: on an accum or image fault check-frame writes its diff images into the dump directory.
  const r = check(ctx.rtoracle, 'check-frame', ['--expected', expected, '--gpu', ctx.dumpDir]);
  const diff = path.join(ctx.dumpDir, 'check-frame.image_diff.png');
  return {...r, check: 'check-frame', images: {expected: path.join(expected, 'image.png'),
    actual: path.join(ctx.dumpDir, 'image.png'), diff: fs.existsSync(diff) ? diff : null}};
}

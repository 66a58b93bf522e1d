// TRACE on the GPU (kernels/trace_rays.wgsl): uploads a bundle's rays, traces one per invocation over a packed scene
// (lib/scene.js) and reads back the hit records, counters and per-ray trace status as words.
import {bind, buffer, pipeline, readBack} from './gpu.js';

export const WFRAY_WORDS = 16;
export const HIT_WORDS = 24;
export const COUNTER_WORDS = 4;
export const TRACE_STATUS = {refused: 1, stackOverflow: 2};
/** trace.wgsl's TRACE_STACK_SIZE: entries of the one stack the TLAS and the BLAS in hand share. */
export const TRACE_STACK_SIZE = 112;
const WORKGROUP = 64;
const MAX_GROUPS_X = 65535;

/** Traces rays (Uint32Array of WfRay words) against an uploaded scene: {hits, counters, status} as Uint32Arrays of
 * HIT_WORDS, COUNTER_WORDS and 1 word per ray. */
export async function traceRays(device, scene, rays, {timer = null} = {}) {
  const n = rays.length / WFRAY_WORDS;
  if (!scene.geometry) throw new Error('the scene has no triangles to trace (a build bundle carries no geometry)');
  // A tree of depth D keeps at most D + 1 entries; the kernel flags an overflow anyway, this names the cause first.
  if (scene.tlasDepth + scene.blasDepth + 2 > TRACE_STACK_SIZE)
    throw new Error(`TLAS depth ${scene.tlasDepth} + BLAS depth ${scene.blasDepth} exceed the trace stack ` +
      `(${TRACE_STACK_SIZE} entries)`);
  const pipe = pipeline(device, 'trace_rays.wgsl');
  const rayBuf = buffer(device, rays.byteLength, {data: rays, label: 'rays'});
  const hitBuf = buffer(device, n * HIT_WORDS * 4, {label: 'hits'});
  const cntBuf = buffer(device, n * COUNTER_WORDS * 4, {label: 'counters'});
  const statusBuf = buffer(device, n * 4, {label: 'trace status'});
  const enc = device.createCommandEncoder();
  if (n > 0) {
    const groups = Math.ceil(n / WORKGROUP);
    const x = Math.min(groups, MAX_GROUPS_X);
    const pass = timer ? timer.pass(enc, 'trace') : enc.beginComputePass({label: 'trace'});
    pass.setPipeline(pipe);
    pass.setBindGroup(0, bind(device, pipe, 0, [rayBuf, hitBuf, cntBuf, statusBuf]));
    pass.setBindGroup(1, bind(device, pipe, 1, [scene.buffer]));
    pass.dispatchWorkgroups(x, Math.ceil(groups / x));
    pass.end();
  }
  const [hits, counters, status] = await readBack(device, enc, [hitBuf, cntBuf, statusBuf],
    [n * HIT_WORDS * 4, n * COUNTER_WORDS * 4, n * 4]);
  for (const b of [rayBuf, hitBuf, cntBuf, statusBuf]) b.destroy();
  return {hits: new Uint32Array(hits), counters: new Uint32Array(counters), status: new Uint32Array(status)};
}

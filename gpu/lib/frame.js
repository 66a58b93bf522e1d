// The wavefront frame on a device (DESIGN.md §7): GENERATE -> PREP -> (TRACE -> SHADE -> PREP) x maxDepth -> RESOLVE,
// recorded once into one command encoder and driven by the GPU itself: PREP turns each queue's emit counter into the
// indirect arguments TRACE and SHADE are dispatched from, so nothing is read back until the frame is done.
//
//   const frame = await renderFrame(device, new Bundle(dir), {timer});   // dir: an `rtoracle render` bundle
//   writeFrameDump(outDir, frame);            // then: rtoracle check-frame --expected dir --gpu outDir
//
// The bundle provides only inputs: the scene (instances, TLAS, BLAS, geometry), camera.npy, the program, its
// parameters and the frame's size and maxDepth. Every dumped buffer is what the kernels wrote.
import path from 'node:path';
import {bind, buffer, pipeline, readBack} from './gpu.js';
import {writeNpy} from './npy.js';
import {writePng} from './png.js';
import {uploadScene} from './scene.js';

/** The built-in programs the kernels implement (wf_programs.wgsl): their PROGRAM define and parameter order. */
export const PROGRAMS = {
  'triangle': {id: 0, params: ['miss']},
  'sun-shadow': {id: 1, params: ['sun_dir', 'sun_color', 'ambient', 'sky']},
};

// The bundle's structured dtypes (DESIGN.md §6, §7), so that a dump reads back as the oracle's files do.
export const WF_RAY_DESCR = "[('origin', '<f4', (3,)), ('tMin', '<f4'), ('dir', '<f4', (3,)), ('tMax', '<f4'), " +
  "('pixel', '<u4'), ('flags', '<u4'), ('cullMask', '<u4'), ('missIndex', '<u4'), ('sbtOffset', '<u4'), " +
  "('payloadSlot', '<u4'), ('kind', '<u4'), ('pad', '<u4')]";
export const HIT_RECORD_DESCR = "[('t', '<f4'), ('instanceId', '<u4'), ('primId', '<u4'), ('hitGroup', '<u4'), " +
  "('bary', '<f4', (2,)), ('customIndex', '<u4'), ('missFlag', '<u4'), ('objToWorld', '<f4', (16,))]";
export const FRAME_COUNTERS_DESCR = "[('emitted', '<u4'), ('queued', '<u4'), ('dropped', '<u4'), ('refused', '<u4'), " +
  "('traced', '<u4'), ('hits', '<u4'), ('misses', '<u4'), ('shaded', '<u4'), ('accumulates', '<u4'), " +
  "('conflicts', '<u4')]";

const RAY_BYTES = 64;
const HIT_BYTES = 96;
const RAY_WORDS = RAY_BYTES / 4;
const PAYLOAD_SLOT_WORD = 13; // WfRay.payloadSlot
// The state buffer of wf_common.wgsl (words).
const STATE_TRACE_FAULTS = 3;
const STATE_COUNTERS = 4;
const COUNTER_WORDS = 10; // FrameCounters
const QUEUED = 1; // FrameCounters.queued
const UNIFORM_ALIGN = 256;

/** The self-intersection offset of shadow rays (§7): 1e-4 max(1, M), M the largest magnitude of the scene bounds and
 * the camera position, as the oracle computes it in binary64 and rounds once. The scene bounds are the union of the
 * instances' world boxes, so their largest magnitude is the largest over instance_aabbs.npy (an empty instance's
 * box is +-inf and, like any non-finite coordinate, left out). */
export function rayOffset(bundle, position) {
  let m = 1;
  const boxes = new Float32Array(bundle.words('instance_aabbs.npy').buffer);
  for (const v of [...boxes, ...position]) if (Number.isFinite(v)) m = Math.max(m, Math.abs(v));
  return Math.fround(1e-4 * m);
}

/** The frame's inputs from a frame bundle's manifest and files. */
export function frameInputs(bundle) {
  const man = bundle.manifest;
  if (man.kind !== 'frame' || man.frame?.scene_kind !== 'mesh')
    throw new Error(`${bundle.dir}: not a frame bundle of a mesh scene`);
  const program = PROGRAMS[man.program?.name];
  if (!program) throw new Error(`${bundle.dir}: program '${man.program?.name}' has no kernels here ` +
    `(${Object.keys(PROGRAMS).join(', ')})`);
  const {width, height, max_depth: maxDepth, capacity, payload_size: payloadSize} = man.frame;
  const camera = new Float32Array(bundle.words('camera.npy').buffer); // inverseProjection, inverseView, position, pad
  const params = new Float32Array(16);
  program.params.forEach((name, i) => {
    const text = man.parameters?.[name];
    if (text === undefined) throw new Error(`${bundle.dir}: the manifest has no parameter ${name}`);
    String(text).split(',').forEach((v, c) => (params[4 * i + c] = Number(v)));
  });
  return {width, height, maxDepth, capacity, payloadWords: payloadSize / 4, program: man.program.name,
    programId: program.id, camera, params, rayOffset: rayOffset(bundle, camera.subarray(32, 35))};
}

/** The Frame uniform block of wf_common.wgsl. */
function frameUniform(f) {
  const u = new Uint32Array(60);
  const fl = new Float32Array(u.buffer);
  u.set([f.width, f.height, f.capacity, f.maxDepth], 0);
  fl.set([f.rayOffset, 1, -1, 0], 4); // rayOffset, one, minusOne, zero
  fl.set(f.camera.subarray(0, 35), 8); // both matrices and the position, then pad3
  fl.set(f.params, 44);
  return u;
}

/** Renders the frame of a bundle on the device. Returns what a harness dumps: {inputs, counters (FrameCounters
 * words, (maxDepth + 1) x 10), indirect ((maxDepth + 1) x 3 words), bounces: [{rays, hits?, payloads?}] (queue d's n
 * records as raw bytes / payload words per ray in the queue's order), accum (Float32Array H W 4), image (RGBA8)}. */
export async function renderFrame(device, bundle, {timer = null} = {}) {
  const f = frameInputs(bundle);
  const D = f.maxDepth;
  const pixels = f.width * f.height;
  const pw = f.payloadWords;
  const defines = {MAX_DEPTH: D, PAYLOAD_WORDS: pw, PROGRAM: f.programId};
  const scene = uploadScene(device, bundle);
  // Validation errors (a binding a kernel lacks, a buffer too small) would otherwise only print: make them throw.
  device.pushErrorScope('validation');
  const pipe = {};
  for (const k of ['generate', 'prep', 'trace', 'shade', 'resolve'])
    pipe[k] = pipeline(device, `wf_${k}.wgsl`, {defines});

  const ownerWord = STATE_COUNTERS + COUNTER_WORDS * (D + 1); // STATE_OWNER
  const frameU = buffer(device, 256, {data: frameUniform(f), usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
  // Stage slots: d = 0 .. D for PREP / TRACE / SHADE d (reads queue d, fills d + 1, counters row d); D + 1 for
  // GENERATE (fills queue 0, counters row 0).
  const stages = new Uint32Array((UNIFORM_ALIGN / 4) * (D + 2));
  for (let d = 0; d <= D; d++) stages.set([d, d + 1, d, 0], (UNIFORM_ALIGN / 4) * d);
  stages.set([0, 0, 0, 0], (UNIFORM_ALIGN / 4) * (D + 1));
  const stageU = buffer(device, stages.byteLength,
    {data: stages, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
  const stage = (k) => ({buffer: stageU, offset: UNIFORM_ALIGN * k, size: 16});

  const state = buffer(device, 4 * (ownerWord + 2 * pixels), {label: 'state'});
  const indirect = buffer(device, 12 * (D + 1), {label: 'indirect',
    usage: GPUBufferUsage.STORAGE | GPUBufferUsage.INDIRECT | GPUBufferUsage.COPY_SRC | GPUBufferUsage.COPY_DST});
  const accum = buffer(device, 16 * pixels, {label: 'accum'});
  const image = buffer(device, 4 * pixels, {label: 'image'});
  const rays = [0, 1].map((i) => buffer(device, RAY_BYTES * f.capacity, {label: `rays${'AB'[i]}`}));
  const payloads = [0, 1].map((i) => buffer(device, 4 * pw * f.capacity, {label: `payloads${'AB'[i]}`}));
  const hits = buffer(device, HIT_BYTES * f.capacity, {label: 'hits'});
  // Queue d's buffers are overwritten two bounces later (ping-pong): each is copied out once SHADE d has read it.
  const dumps = Array.from({length: D + 1}, (_, d) => ({
    rays: buffer(device, RAY_BYTES * f.capacity),
    payloads: buffer(device, 4 * pw * f.capacity),
    hits: d < D ? buffer(device, HIT_BYTES * f.capacity) : null,
  }));

  const enc = device.createCommandEncoder();
  const run = (label, p, entries, dispatch, withScene = false) => {
    const pass = timer ? timer.pass(enc, label) : enc.beginComputePass({label});
    pass.setPipeline(p);
    pass.setBindGroup(0, bind(device, p, 0, entries));
    if (withScene) pass.setBindGroup(1, bind(device, p, 1, [scene.buffer]));
    dispatch(pass);
    pass.end();
  };
  enc.clearBuffer(state); // emit counters, FrameCounters, owner and conflict words
  run('generate', pipe.generate, {0: frameU, 1: stage(D + 1), 2: state, 3: accum, 4: rays[0], 5: payloads[0]},
    (pass) => pass.dispatchWorkgroups(Math.ceil(f.width / 8), Math.ceil(f.height / 8)));
  for (let d = 0; d <= D; d++) {
    const cur = d % 2, next = (d + 1) % 2;
    run('prep', pipe.prep, {0: frameU, 1: stage(d), 2: state, 3: indirect}, (pass) => pass.dispatchWorkgroups(1));
    if (d < D) { // the last queue is never traced
      run('trace', pipe.trace, {1: stage(d), 2: state, 3: rays[cur], 4: hits},
        (pass) => pass.dispatchWorkgroupsIndirect(indirect, 12 * d), true);
      enc.clearBuffer(state, 4 * ownerWord, 4 * pixels); // conflicts are per pass
      run('shade', pipe.shade, {0: frameU, 1: stage(d), 2: state, 3: accum, 4: rays[next], 5: payloads[next],
        6: rays[cur], 7: hits, 8: payloads[cur]}, (pass) => pass.dispatchWorkgroupsIndirect(indirect, 12 * d), true);
      enc.copyBufferToBuffer(hits, 0, dumps[d].hits, 0, hits.size);
    }
    enc.copyBufferToBuffer(rays[cur], 0, dumps[d].rays, 0, rays[cur].size);
    enc.copyBufferToBuffer(payloads[cur], 0, dumps[d].payloads, 0, payloads[cur].size);
  }
  run('resolve', pipe.resolve, {0: frameU, 2: accum, 3: image},
    (pass) => pass.dispatchWorkgroups(Math.ceil(f.width / 8), Math.ceil(f.height / 8)));
  const dumpBufs = dumps.flatMap((q) => [q.rays, q.payloads, q.hits].filter(Boolean));
  const [stateW, indirectW, accumB, imageB, ...dumpB] = await readBack(device, enc,
    [state, indirect, accum, image, ...dumpBufs]);
  const invalid = await device.popErrorScope();
  if (invalid) throw new Error(`WebGPU validation: ${invalid.message.split('\n')[0]}`);
  [frameU, stageU, state, indirect, accum, image, ...rays, ...payloads, hits, scene.buffer, ...dumpBufs]
    .forEach((b) => b.destroy());

  const faults = new Uint32Array(stateW, 0, 4)[STATE_TRACE_FAULTS];
  if (faults) throw new Error(`TRACE: ${faults} ray(s) refused or past the traversal stack (trace.wgsl's status)`);
  const counters = new Uint32Array(stateW, 4 * STATE_COUNTERS, COUNTER_WORDS * (D + 1));
  const bounces = dumps.map((q, d) => {
    const n = counters[COUNTER_WORDS * d + QUEUED]; // the GPU's own queue length (PREP d's n)
    const raysB = dumpB.shift(), payB = dumpB.shift(), hitsB = q.hits ? dumpB.shift() : null;
    const r = new Uint32Array(raysB, 0, RAY_WORDS * n);
    // The payload store is indexed by payloadSlot; the dump lists each ray's payload in the queue's order.
    const store = new Uint32Array(payB);
    const p = new Uint32Array(pw * n);
    for (let i = 0; i < n; i++) {
      const slot = r[RAY_WORDS * i + PAYLOAD_SLOT_WORD];
      p.set(store.subarray(pw * slot, pw * slot + pw), pw * i);
    }
    return {n, rays: new Uint8Array(raysB, 0, RAY_BYTES * n), payloads: p,
      hits: hitsB ? new Uint8Array(hitsB, 0, HIT_BYTES * n) : null};
  });
  return {inputs: f, counters: counters.slice(), indirect: new Uint32Array(indirectW, 0, 3 * (D + 1)).slice(), bounces,
    accum: new Float32Array(accumB, 0, 4 * pixels), image: new Uint8Array(imageB, 0, 4 * pixels)};
}

/** Writes a rendered frame into dir under the bundle's file names and dtypes (what check-frame reads). */
export function writeFrameDump(dir, frame) {
  const {width, height, maxDepth: D, payloadWords: pw} = frame.inputs;
  const rows = D + 1;
  const file = (name) => path.join(dir, name);
  writeNpy(file('emit_counts.npy'), Uint32Array.from({length: rows}, (_, d) => frame.counters[COUNTER_WORDS * d]));
  writeNpy(file('indirect_args.npy'), frame.indirect, [rows, 3]);
  writeNpy(file('frame_counters.npy'), frame.counters, [rows], FRAME_COUNTERS_DESCR);
  frame.bounces.forEach((q, d) => {
    writeNpy(file(`bounce_${d}_rays.npy`), q.rays, [q.n], WF_RAY_DESCR);
    if (pw) writeNpy(file(`bounce_${d}_payloads.npy`), q.payloads, [q.n, pw]);
    if (q.hits) writeNpy(file(`bounce_${d}_hits.npy`), q.hits, [q.n], HIT_RECORD_DESCR);
  });
  writeNpy(file('accum.npy'), frame.accum, [height, width, 4]);
  writePng(file('image.png'), width, height, frame.image);
}

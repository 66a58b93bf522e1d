// Sorts on a device (DESIGN.md §4): the canonical bitonic network with one dispatch per (k, j) pass or in one
// workgroup with barriers between passes, and the LSD radix sort with every intermediate read back.
import {buffer, bind, grid, pipeline, readBack} from './gpu.js';

export const SENTINEL = 0xFFFFFFFF;

/** The canonical schedule for n_padded slots: [k, j] per pass. */
export function bitonicPasses(n) {
  const passes = [];
  for (let k = 2; k <= n; k <<= 1) for (let j = k >> 1; j > 0; j >>= 1) passes.push([k, j]);
  return passes;
}

/** next_pow2(n) (1 for n = 0 or 1). */
export function padded(n) {
  let p = 1;
  while (p < n) p *= 2;
  return p;
}

/** keys (Uint32Array) padded with the sentinel to n_padded. */
export function padKeys(keys) {
  const out = new Uint32Array(padded(keys.length)).fill(SENTINEL);
  out.set(keys);
  return out;
}

/** Records the network over the n (a power of two) u32 slots of buf into enc, one compute pass per (k, j), GPU-resident
 * (for callers that keep their keys on the device, such as a BVH build). With dump (a buffer of passes x n words) the
 * buffer is copied there after every pass. timer (lib/timing.js) measures the passes as 'bitonic_pass'. Returns the
 * uniform buffer of pass parameters, which the caller destroys after submitting. */
export function encodeBitonic(device, enc, buf, n, {timer = null, dump = null} = {}) {
  const pipe = pipeline(device, 'bitonic_pass.wgsl');
  const passes = bitonicPasses(n);
  const params = buffer(device, 256 * Math.max(1, passes.length),
    {usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
  const words = new Uint32Array(64 * Math.max(1, passes.length));
  passes.forEach(([k, j], p) => words.set([k, j, n, 0], 64 * p));
  device.queue.writeBuffer(params, 0, words);
  passes.forEach((_, p) => {
    const pass = timer ? timer.pass(enc, 'bitonic_pass') : enc.beginComputePass();
    pass.setPipeline(pipe);
    pass.setBindGroup(0, bind(device, pipe, 0, [buf, {buffer: params, offset: 256 * p, size: 16}]));
    pass.dispatchWorkgroups(...grid(Math.ceil(n / 64)));
    pass.end();
    if (dump) enc.copyBufferToBuffer(buf, 0, dump, p * 4 * n, 4 * n);
  });
  return params;
}

/** Sorts keys on the GPU with one dispatch per pass: {sorted: all n_padded slots, as a harness dumps its buffer,
 * passes: with dumpPasses, a Uint32Array (passes x n_padded) of the buffer after every pass, passTable: [k, j]}. */
export async function bitonicSort(device, keys, {dumpPasses = false, timer = null} = {}) {
  const slots = padKeys(keys);
  const n = slots.length;
  const passes = bitonicPasses(n);
  const buf = buffer(device, slots.byteLength, {data: slots});
  const dump = dumpPasses ? buffer(device, Math.max(1, passes.length) * slots.byteLength) : null;
  const enc = device.createCommandEncoder();
  const params = encodeBitonic(device, enc, buf, n, {timer, dump});
  const [out, all] = await readBack(device, enc, dump ? [buf, dump] : [buf],
    dump ? [slots.byteLength, passes.length * slots.byteLength] : [slots.byteLength]);
  buf.destroy();
  params.destroy();
  if (dump) dump.destroy();
  return {sorted: new Uint32Array(out), passes: all ? new Uint32Array(all) : null, passTable: passes};
}

/** The most keys one workgroup sorts in bitonic_wg.wgsl (the seeds' TLAS_BVH_N_PADDED). */
export const WG_MAX_KEYS = 16384;

/** Sorts keys (at most WG_MAX_KEYS) with the whole network in ONE workgroup, barriers between passes. Returns what
 * bitonicSort returns. dropBarrier: leave out the barrier after that pass (a planted race), or null. */
export async function bitonicSortWg(device, keys, {dumpPasses = false, timer = null, dropBarrier = null} = {}) {
  const slots = padKeys(keys);
  const n = slots.length;
  if (n > WG_MAX_KEYS) throw new Error(`bitonic-wg sorts at most ${WG_MAX_KEYS} keys, not ${keys.length}`);
  const passes = bitonicPasses(n);
  const pipe = pipeline(device, 'bitonic_wg.wgsl', {defines: {DROP_BARRIER: dropBarrier ?? SENTINEL}});
  const buf = buffer(device, slots.byteLength, {data: slots});
  // Without dumping the kernel never touches `passes`, but the binding still needs a buffer.
  const dump = buffer(device, dumpPasses ? passes.length * slots.byteLength : 16);
  const params = buffer(device, 16, {data: new Uint32Array([n, dumpPasses ? 1 : 0, 0, 0]),
    usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
  const enc = device.createCommandEncoder();
  const pass = timer ? timer.pass(enc, 'bitonic_wg') : enc.beginComputePass();
  pass.setPipeline(pipe);
  pass.setBindGroup(0, bind(device, pipe, 0, [buf, dump, params]));
  pass.dispatchWorkgroups(1);
  pass.end();
  const [out, all] = await readBack(device, enc, dumpPasses ? [buf, dump] : [buf],
    dumpPasses ? [slots.byteLength, passes.length * slots.byteLength] : [slots.byteLength]);
  for (const b of [buf, dump, params]) b.destroy();
  return {sorted: new Uint32Array(out), passes: all ? new Uint32Array(all) : null, passTable: passes};
}

/** LSD radix parameters of the radix_*.wgsl kernels (DESIGN.md §4): 4-bit digits, so 8 passes over u32 keys, and a
 * tile of 256 keys per workgroup (128 invocations x 2 keys): pass the same tile to the oracle (--tile). */
export const RADIX_BITS = 4;
export const RADIX_PASSES = 32 / RADIX_BITS;
export const RADIX_TILE = 256;
const RADIX = 1 << RADIX_BITS;

/** Sorts keys (u32) by LSD radix with values = source indices, every intermediate kept on the device and read back:
 * {keys, values: the n sorted keys and their source indices, passes, passValues: (RADIX_PASSES x n) keys and values
 * after every pass's scatter, hist and base: (passes x tiles x 16) tile histograms and scatter bases, prefix:
 * (passes x 16) digit prefixes, tiles}. racy: the unsynchronised scatter (radix_scatter.wgsl's RACY_SCATTER). passes
 * false: no per-pass copies (passes and passValues empty), which a sweep of large sizes needs (8 copies of 2^24 keys
 * exceed WebGPU's default maxBufferSize). Dispatches over more than 65,535 tiles use a 2-D grid (gpu.js grid()). */
export async function radixSort(device, keys, {timer = null, racy = false, passes = true} = {}) {
  const n = keys.length;
  const tiles = Math.ceil(n / RADIX_TILE);
  const bytes = 4 * n;
  const pipes = {
    hist: pipeline(device, 'radix_hist.wgsl'),
    prefix: pipeline(device, 'radix_prefix.wgsl'),
    scatter: pipeline(device, 'radix_scatter.wgsl', {defines: {RACY_SCATTER: racy}}),
  };
  // Ping-pong key and value buffers: pass p reads side p % 2 and writes the other.
  const keyBufs = [buffer(device, bytes, {data: keys}), buffer(device, bytes)];
  const valBufs = [buffer(device, bytes, {data: Uint32Array.from({length: n}, (_, i) => i)}), buffer(device, bytes)];
  const tableBytes = 4 * RADIX_PASSES * tiles * RADIX, prefixBytes = 4 * RADIX_PASSES * RADIX;
  const hist = buffer(device, tableBytes);
  const base = buffer(device, tableBytes);
  const prefix = buffer(device, prefixBytes);
  const dump = buffer(device, passes ? RADIX_PASSES * bytes : 16);
  const dumpValues = buffer(device, passes ? RADIX_PASSES * bytes : 16);
  const params = buffer(device, 256 * RADIX_PASSES, {usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
  const words = new Uint32Array(64 * RADIX_PASSES);
  for (let p = 0; p < RADIX_PASSES; p++) words.set([n, tiles, p * RADIX_BITS, p], 64 * p);
  device.queue.writeBuffer(params, 0, words);

  const enc = device.createCommandEncoder();
  const stage = (label, pipe, bufs, groups) => {
    const pass = timer ? timer.pass(enc, label) : enc.beginComputePass();
    pass.setPipeline(pipe);
    pass.setBindGroup(0, bind(device, pipe, 0, bufs));
    pass.dispatchWorkgroups(...grid(groups));
    pass.end();
  };
  for (let p = 0; p < RADIX_PASSES; p++) {
    const uniform = {buffer: params, offset: 256 * p, size: 16};
    const [kIn, kOut, vIn, vOut] = [keyBufs[p % 2], keyBufs[1 - p % 2], valBufs[p % 2], valBufs[1 - p % 2]];
    stage('radix_hist', pipes.hist, [kIn, hist, uniform], tiles);
    stage('radix_prefix', pipes.prefix, [hist, prefix, base, uniform], 1);
    stage('radix_scatter', pipes.scatter, [kIn, vIn, kOut, vOut, base, uniform], tiles);
    if (n && passes) {
      enc.copyBufferToBuffer(kOut, 0, dump, p * bytes, bytes);
      enc.copyBufferToBuffer(vOut, 0, dumpValues, p * bytes, bytes);
    }
  }
  // An even pass count leaves the result where it started.
  const sides = [keyBufs[RADIX_PASSES % 2], valBufs[RADIX_PASSES % 2], dump, dumpValues, hist, prefix, base];
  const out = await readBack(device, enc, sides, [bytes, bytes, passes ? RADIX_PASSES * bytes : 0,
    passes ? RADIX_PASSES * bytes : 0, tableBytes, prefixBytes, tableBytes]);
  for (const b of [...keyBufs, ...valBufs, hist, base, prefix, dump, dumpValues, params]) b.destroy();
  const [k, v, kp, vp, h, pre, b] = out.map((a) => new Uint32Array(a));
  return {keys: k, values: v, passes: passes ? kp : new Uint32Array(0), passValues: passes ? vp : new Uint32Array(0),
    hist: h, prefix: pre, base: b, tiles};
}

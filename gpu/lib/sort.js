// The bitonic sort kernels on a device: one dispatch per (k, j) pass of the canonical network (DESIGN.md §4).
import fs from 'node:fs';

const SENTINEL = 0xFFFFFFFF;

function kernel(device, file) {
  const code = fs.readFileSync(new URL(`../kernels/${file}`, import.meta.url), 'utf8');
  return device.createComputePipeline({layout: 'auto', compute: {module: device.createShaderModule({code}),
    entryPoint: 'main'}});
}

/** The canonical schedule for n_padded slots: [k, j] per pass. */
export function bitonicPasses(n) {
  const passes = [];
  for (let k = 2; k <= n; k <<= 1) for (let j = k >> 1; j > 0; j >>= 1) passes.push([k, j]);
  return passes;
}

/** Pads keys (Uint32Array) with the sentinel to n_padded = next_pow2(n), sorts them on the GPU with one dispatch per
 * pass and returns the whole buffer (n_padded slots), as a GPU harness dumps it. */
export async function bitonicSort(device, keys) {
  let n = 1;
  while (n < keys.length) n *= 2;
  const padded = new Uint32Array(n).fill(SENTINEL);
  padded.set(keys);
  const pipeline = kernel(device, 'bitonic_pass.wgsl');
  const buf = device.createBuffer({size: Math.max(16, padded.byteLength),
    usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC | GPUBufferUsage.COPY_DST});
  device.queue.writeBuffer(buf, 0, padded);
  const passes = bitonicPasses(n);
  const params = device.createBuffer({size: 256 * Math.max(1, passes.length),
    usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
  const words = new Uint32Array(64 * Math.max(1, passes.length));
  passes.forEach(([k, j], p) => words.set([k, j, n, 0], 64 * p));
  device.queue.writeBuffer(params, 0, words);
  const enc = device.createCommandEncoder();
  passes.forEach((_, p) => {
    const bind = device.createBindGroup({layout: pipeline.getBindGroupLayout(0), entries: [
      {binding: 0, resource: {buffer: buf}}, {binding: 1, resource: {buffer: params, offset: 256 * p, size: 16}}]});
    const pass = enc.beginComputePass();
    pass.setPipeline(pipeline);
    pass.setBindGroup(0, bind);
    pass.dispatchWorkgroups(Math.ceil(n / 64));
    pass.end();
  });
  const out = await readBack(device, enc, buf, padded.byteLength);
  buf.destroy();
  params.destroy();
  return new Uint32Array(out);
}

/** Copies bytes of buf out through a mapped buffer (finishing enc). */
export async function readBack(device, enc, buf, bytes) {
  const read = device.createBuffer({size: buf.size, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST});
  enc.copyBufferToBuffer(buf, 0, read, 0, buf.size);
  device.queue.submit([enc.finish()]);
  // Dawn's callbacks are not libuv handles: keep the event loop alive while the GPU works.
  const alive = setInterval(() => {}, 5);
  try {
    await read.mapAsync(GPUMapMode.READ);
  } finally {
    clearInterval(alive);
  }
  const copy = read.getMappedRange().slice(0, bytes);
  read.unmap();
  read.destroy();
  return copy;
}

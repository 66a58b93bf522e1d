// Sorts a keys.npy (u32) with the canonical bitonic network, one dispatch per (k, j) pass, and writes the GPU's
// buffer (all n_padded slots) to OUT.npy:  node gpu/bitonic.js keys.npy OUT.npy
import fs from 'node:fs';
import {readNpy, writeNpy} from './lib/npy.js';
import {openDevice} from './lib/device.js';

const [input, output] = process.argv.slice(2);
const {data: keys} = readNpy(input);
let n = 1;
while (n < keys.length) n *= 2;
const padded = new Uint32Array(Math.max(n, 1)).fill(0xFFFFFFFF);
padded.set(keys);
const {device, backend, gpu} = await openDevice();
globalThis.rtoGpu = gpu; // the Dawn instance must outlive every object made from it
const code = fs.readFileSync(new URL('./kernels/bitonic_pass.wgsl', import.meta.url), 'utf8');
const pipeline = device.createComputePipeline({layout: 'auto', compute: {module: device.createShaderModule({code}),
  entryPoint: 'main'}});
const buf = device.createBuffer({size: Math.max(16, padded.byteLength),
  usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC | GPUBufferUsage.COPY_DST});
device.queue.writeBuffer(buf, 0, padded);
const passes = [];
for (let k = 2; k <= n; k <<= 1) for (let j = k >> 1; j > 0; j >>= 1) passes.push([k, j]);
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
const read = device.createBuffer({size: buf.size, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST});
enc.copyBufferToBuffer(buf, 0, read, 0, buf.size);
device.queue.submit([enc.finish()]);
// Dawn's callbacks are not libuv handles: keep the event loop alive while the GPU works.
const alive = setInterval(() => {}, 5);
await read.mapAsync(GPUMapMode.READ);
clearInterval(alive);
const out = new Uint32Array(read.getMappedRange().slice(0, padded.byteLength));
writeNpy(output, out);
console.log(`bitonic ${keys.length} keys (n_padded ${n}, ${passes.length} passes) on ${backend}`);

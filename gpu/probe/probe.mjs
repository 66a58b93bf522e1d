// A device's rgba16float trilinear filtering, and the samples of chosen raymarch pixels (DESIGN.md §12.5.1).
//
//   node gpu/probe/probe.mjs OUTDIR [RMDIR X,Y ...]...
//
// Writes OUTDIR/adapter.txt; queries.f32 (8,192 uvw, the first 4,096 a fine sweep across one texel in x), texA.f16 /
// texB.f16 (8^3 rgba16float: R = x & 1, G = 1000 + 0.5 (x & 1), B = y & 1, A = z & 1; random values in [0.25, 2])
// and filterA.f32 / filterB.f32 (textureSampleLevel through a linear clamp-to-edge sampler) for gpu/probe/filter.py;
// opsA.f32 / opsB.f32 (exp, sqrt, 1/x and a*b+c of the queries, for comparing a device's arithmetic). For each raymarch
// bundle RMDIR (rtoracle raymarch) and its pixels X,Y: kernels/fluid_raymarch.wgsl with every sample_density call of
// those pixels recorded (q.xyz, the filtered texel value) and markers (-1e30, bounce, k, t), (-2e30, dRefr, Tr, dRefl),
// (-3e30, R, tir, 0), into NAME-skipS.dbg (f32 vec4 records, 16,384 a pixel, the first holding the count), with the
// image (.image) and step counts (.steps) of the whole frame, once with the bundle's skip flag and once without.
import fs from 'node:fs';
import path from 'node:path';
import {openDevice} from '../lib/device.js';
import {Bundle} from '../lib/bundle.js';
import {densityTexture, linearSampler} from '../cases/fluid.js';
import {buffer, readBack} from '../lib/gpu.js';

const out = process.argv[2];
fs.mkdirSync(out, {recursive: true});
const {device, adapter} = await openDevice();
const info = adapter.info || {};
fs.writeFileSync(path.join(out, 'adapter.txt'),
  `${info.vendor} ${info.architecture} ${info.device} ${info.description}\n`);

function f16(x) { // round-to-nearest-even binary16 bits of a double (normal range only)
  const f = new Float32Array([x]); const u = new Uint32Array(f.buffer)[0];
  const s = (u >>> 16) & 0x8000; let e = ((u >>> 23) & 0xff) - 127 + 15; let m = u & 0x7fffff;
  if (x === 0) return 0;
  if (e <= 0) throw new Error('subnormal');
  let h = s | (e << 10) | (m >>> 13); const rem = m & 0x1fff;
  if (rem > 0x1000 || (rem === 0x1000 && (h & 1))) h++;
  return h;
}
let seed = 12345;
/** A uniform value in [0, 1) from a linear congruential generator (the probe's inputs are written out with it). */
function rnd() {
  seed = (seed * 1103515245 + 12345) >>> 0;
  return ((seed >>> 8) & 0xffff) / 65536 + (seed >>> 24) / 16777216;
}

// Part 1: filtering. Texture A 8^3: R = x&1, G = 1000 + 0.5*(x&1), B = y&1, A = z&1. Texture B 8^3 random in [0, 2].
const N = 8;
const texA = new Uint16Array(N * N * N * 4), texB = new Uint16Array(N * N * N * 4);
for (let z = 0; z < N; z++) for (let y = 0; y < N; y++) for (let x = 0; x < N; x++) {
  const i = 4 * ((z * N + y) * N + x);
  texA.set([f16(x & 1), f16(1000 + 0.5 * (x & 1)), f16(y & 1), f16(z & 1)], i);
  for (let c = 0; c < 4; c++) texB[i + c] = f16(Math.fround(0.25 + rnd() * 1.75));
}
const Q = 8192;
const qs = new Float32Array(Q * 4);
for (let i = 0; i < Q; i++) {
  let u, v, w;
  if (i < 4096) { u = (3 + 0.5 + i / 4096) / N; v = (2.5 + rnd()) / N; w = (4.5 + rnd()) / N; }  // a fine sweep in x
  else { u = (0.5 + rnd() * 7) / N; v = (0.5 + rnd() * 7) / N; w = (0.5 + rnd() * 7) / N; }
  qs.set([u, v, w, 0], 4 * i);
}
fs.writeFileSync(path.join(out, 'queries.f32'), Buffer.from(qs.buffer));
fs.writeFileSync(path.join(out, 'texA.f16'), Buffer.from(texA.buffer));
fs.writeFileSync(path.join(out, 'texB.f16'), Buffer.from(texB.buffer));
const FILTER = `
@group(0) @binding(0) var tex: texture_3d<f32>;
@group(0) @binding(1) var samp: sampler;
@group(0) @binding(2) var<storage, read> q: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> o: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> ops: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
  let i = g.x;
  if (i >= arrayLength(&q)) { return; }
  o[i] = textureSampleLevel(tex, samp, q[i].xyz, 0.0);
  let a = q[i].x * 7.3; let b = q[i].y * 5.1 - 2.0; let c = q[i].z;
  ops[i] = vec4<f32>(exp(-a), sqrt(a), 1.0 / b, a * b + c);
}`;
const mod = device.createShaderModule({code: FILTER});
const pipe = device.createComputePipeline({layout: 'auto', compute: {module: mod, entryPoint: 'main'}});
const sampler = linearSampler(device);
for (const [name, data] of [['A', texA], ['B', texB]]) {
  const tex = device.createTexture({size: [N, N, N], dimension: '3d', format: 'rgba16float',
    usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST});
  device.queue.writeTexture({texture: tex}, data, {bytesPerRow: 8 * N, rowsPerImage: N}, [N, N, N]);
  const qb = buffer(device, qs.byteLength, {data: qs}), ob = buffer(device, Q * 16), opb = buffer(device, Q * 16);
  const enc = device.createCommandEncoder();
  const pass = enc.beginComputePass();
  pass.setPipeline(pipe);
  pass.setBindGroup(0, device.createBindGroup({layout: pipe.getBindGroupLayout(0), entries: [
    {binding: 0, resource: tex.createView()}, {binding: 1, resource: sampler}, {binding: 2, resource: {buffer: qb}},
    {binding: 3, resource: {buffer: ob}}, {binding: 4, resource: {buffer: opb}}]}));
  pass.dispatchWorkgroups(Q / 64);
  pass.end();
  const r = await readBack(device, enc, [ob, opb], [Q * 16, Q * 16]);
  fs.writeFileSync(path.join(out, `filter${name}.f32`), Buffer.from(r[0]));
  fs.writeFileSync(path.join(out, `ops${name}.f32`), Buffer.from(r[1]));
}

// Part 2: traced raymarch. Every sample_density call of the listed pixels: (q.xyz, texel value), and markers.
const here = path.dirname(new URL(import.meta.url).pathname);
let src = fs.readFileSync(path.join(here, '../kernels/fluid_raymarch.wgsl'), 'utf8');
src = src.replace('const NONE', `@group(0) @binding(7) var<storage, read_write> dbg: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> targets: array<u32>;
var<private> g_slot: i32;
var<private> g_n: u32;
fn rec(v: vec4<f32>) {
  if (g_slot < 0 || g_n >= 16383u) { return; }
  dbg[u32(g_slot) * 16384u + 1u + g_n] = v;
  g_n++;
  dbg[u32(g_slot) * 16384u] = vec4<f32>(f32(g_n), 0.0, 0.0, 0.0);
}
const NONE`);
src = src.replace('let t = textureSampleLevel(density, samp, uvw, 0.0).r;',
  'let t = textureSampleLevel(density, samp, uvw, 0.0).r;\n  rec(vec4<f32>(q, t));');
src = src.replace('g_steps = 0u;', `g_steps = 0u;
  g_slot = -1; g_n = 0u;
  for (var s = 0u; s < arrayLength(&targets); s++) { if (targets[s] == g_pixel) { g_slot = i32(s); } }`);
src = src.replace('if (b == 0u) { first = h.k; }', `if (b == 0u) { first = h.k; }
    rec(vec4<f32>(-1.0e30, f32(b), f32(h.k), h.t));`);
src = src.replace('if (dRefr * Tr > dRefl * R) {', `rec(vec4<f32>(-2.0e30, dRefr, Tr, dRefl));
    rec(vec4<f32>(-3.0e30, R, select(0.0, 1.0, tir), 0.0));
    if (dRefr * Tr > dRefl * R) {`);
fs.writeFileSync(path.join(out, 'traced.wgsl'), src);
const tmod = device.createShaderModule({code: src});
const info2 = await tmod.getCompilationInfo();
for (const m of info2.messages) console.error(m.type, m.lineNum, m.message);
const tpipe = device.createComputePipeline({layout: 'auto', compute: {module: tmod, entryPoint: 'main'}});
for (let a = 3; a < process.argv.length;) {
  const dir = process.argv[a++];
  const pix = [];
  while (a < process.argv.length && /^\d+,\d+$/.test(process.argv[a]))
    pix.push(process.argv[a++].split(',').map(Number));
  const rm = new Bundle(dir);
  const u = rm.npy('rm_params.npy').data;
  const occ = rm.words('occupancy.npy');
  const tex = densityTexture(device, rm);
  const [W, H] = [u[56], u[57]];
  const tg = new Uint32Array(pix.map(([x, y]) => y * W + x));
  for (const skip of [u[58], 0]) {
    const params = new Float32Array(u); params[58] = skip;
    const ub = buffer(device, 256, {data: params, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
    const n = W * H;
    const bufs = [buffer(device, n * 16), buffer(device, n * 4), buffer(device, n * 4)];
    const dbg = buffer(device, tg.length * 16384 * 16), tb = buffer(device, tg.byteLength, {data: tg});
    const occb = buffer(device, occ.byteLength, {data: occ});
    const enc = device.createCommandEncoder();
    const pass = enc.beginComputePass();
    pass.setPipeline(tpipe);
    pass.setBindGroup(0, device.createBindGroup({layout: tpipe.getBindGroupLayout(0), entries: [
      {binding: 0, resource: {buffer: ub}}, {binding: 1, resource: tex.createView()}, {binding: 2, resource: sampler},
      {binding: 3, resource: {buffer: occb}}, {binding: 4, resource: {buffer: bufs[0]}},
      {binding: 5, resource: {buffer: bufs[1]}}, {binding: 6, resource: {buffer: bufs[2]}},
      {binding: 7, resource: {buffer: dbg}}, {binding: 8, resource: {buffer: tb}}]}));
    pass.dispatchWorkgroups(Math.ceil(W / 8), Math.ceil(H / 8));
    pass.end();
    const r = await readBack(device, enc, [dbg, bufs[0], bufs[2]], [tg.length * 16384 * 16, n * 16, n * 4]);
    const base = path.join(out, `${path.basename(path.dirname(dir))}-skip${skip}`);
    fs.writeFileSync(`${base}.dbg`, Buffer.from(r[0]));
    fs.writeFileSync(`${base}.image`, Buffer.from(r[1]));
    fs.writeFileSync(`${base}.steps`, Buffer.from(r[2]));
    fs.writeFileSync(`${base}.pix`, JSON.stringify(pix));
  }
}
console.log('probe done');

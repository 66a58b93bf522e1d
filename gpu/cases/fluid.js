// Case family "fluid": seed 003's density volume (DESIGN.md §12). rtoracle splat writes the bundle (fluid_params.npy,
// the 64-byte uniform block; particles.npy; the oracle's volume_u32.npy, volume_f16.npy and occupancy.npy, the
// manifest's occupancy levels); the GPU runs the seed's three passes on the bundle's inputs alone —
// kernels/fluid_splat_clear.wgsl (zero the u32 volume), fluid_splat.wgsl (one thread per particle, atomicAdd of
// u32(K(r) * scale) into every voxel within h), fluid_resolve.wgsl (f32(u) / scale into an rgba16float 3-D storage
// texture) — and builds the occupancy grid from the particles (fluid_occupancy.wgsl: level 0 by atomicOr, one thread
// per particle, then one mip pass per level); the texture is copied to a buffer and everything is dumped as
// volume_u32.npy (nz, ny, nx), volume_f16.npy (nz, ny, nx, 4) and occupancy.npy (every level's words), which
// rtoracle check-volume validates against §12.2's conformance model and §12.3's lossless rule.
// The raymarch cases (`rm`, with and without --skip) then run kernels/fluid_raymarch.wgsl on the resolved texture
// through a linear-filtering sampler (textureSampleLevel) and check its dump with rtoracle check-raymarch.
//
// WebGPU compatibility mode on Mesa llvmpipe (Dawn's OpenGL backend, featureLevel 'compatibility'; Mesa 22.3.6), as
// found running this family:
//   - rgba16float 3-D storage textures (texture_storage_3d<rgba16float, write>): allowed, and textureStore works, as
//     do r32float, rgba32float, r32uint and rgba8unorm; r16float has no STORAGE_BINDING (as in core WebGPU, the seed's
//     note on an R-only volume).
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {buffer, grid, pipeline, readBack} from '../lib/gpu.js';
import {writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';

export const family = 'fluid';

const WG = 256;

const fluidCase = (gen, res, extra = {}) => {
  const c = {family, gen, res, occupancy: extra.occupancy || 8, radius: extra.radius || null, rm: extra.rm || null};
  const bits = [gen, `r${res}`, `o${c.occupancy}`];
  if (c.radius) bits.push(`h${c.radius}`);
  if (c.rm) bits.push(`rm-${c.rm.width}x${c.rm.height}${c.rm.skip ? '-skip' : ''}`);
  return {...c, id: `fluid/${bits.join('/')}`};
};

/** ci: dambreak, splash and the lattice at 24^3 voxels (8^3 occupancy), single at 16^3; full: also pool, larger
 * volumes and particle counts, other radii and occupancy resolutions. --scenes: each generator spec named
 * (rtoracle splat --gen, e.g. pool:500) at 24^3 voxels. */
export function list(opts) {
  if (opts.scenes) return opts.scenes.map((g) => fluidCase(g, 24));
  const ci = [fluidCase('dambreak:2000', 24), fluidCase('splash:1000', 24), fluidCase('single', 16),
    fluidCase('lattice', 24)];
  if (opts.subset === 'ci') return ci;
  return [...ci, fluidCase('pool:4000', 32), fluidCase('dambreak:20000', 48, {occupancy: 16}),
    fluidCase('splash:8000', 40, {occupancy: 32}), fluidCase('pool:30000', 64, {occupancy: 32}),
    fluidCase('lattice', 33, {occupancy: 7}), fluidCase('single', 31, {occupancy: 5, radius: 0.3}),
    fluidCase('dambreak:5000', 32, {radius: 0.12})];
}

/** The oracle's splat bundle: the GPU's inputs and the volume and occupancy it must match. */
export function prepare(ctx, c) {
  const args = ['splat', '--gen', c.gen, '--res', String(c.res), '--occupancy', String(c.occupancy)];
  if (c.radius) args.push('--radius', String(c.radius));
  rtoracle(ctx.rtoracle, [...args, '-o', path.join(ctx.dir, 'expected')]);
}

/** The occupancy levels (DESIGN.md §12.3): cells per axis and first word of each, level 0 first, down to 1 cell. */
export function occupancyLevels(o) {
  const res = [], offset = [];
  let at = 0;
  for (let r = o; ; r = Math.ceil(r / 2)) {
    res.push(r);
    offset.push(at);
    at += Math.ceil((r * r * r) / 32);
    if (r === 1) break;
  }
  return {res, offset, words: at};
}

/** The splat's inputs from a bundle: {uniforms (Float32Array(16)), particles (Float32Array, 3 a particle), nx, ny, nz,
 * levels}, every size checked before anything is allocated on the device. */
export function splatInputs(bundle) {
  const uniforms = bundle.npy('fluid_params.npy').data;
  if (!(uniforms instanceof Float32Array) || uniforms.length !== 16)
    throw new Error(`${bundle.dir}: fluid_params.npy is not f32 (16,)`);
  const particles = bundle.npy('particles.npy').data;
  if (!(particles instanceof Float32Array) || particles.length % 3)
    throw new Error(`${bundle.dir}: particles.npy is not f32 (N, 3)`);
  const [nx, ny, nz] = [uniforms[12], uniforms[13], uniforms[14]];
  const o = uniforms[15];
  for (const [name, v, hi] of [['res x', nx, 1024], ['res y', ny, 1024], ['res z', nz, 1024], ['occupancy', o, 1024]])
    if (!Number.isInteger(v) || v < 1 || v > hi) throw new Error(`${bundle.dir}: fluid_params.npy: ${name} ${v}`);
  if (nx * ny * nz * 8 > 128 * 1024 * 1024) throw new Error(`${bundle.dir}: ${nx}x${ny}x${nz} voxels (at most 128 MiB)`);
  const levels = occupancyLevels(o);
  const m = bundle.manifest.fluid || bundle.manifest.splat || null;
  const fromManifest = m && (m.occupancy_offsets || m.level_offset || m.occupancy_level_offsets);
  if (fromManifest && fromManifest.join() !== levels.offset.join())
    throw new Error(`${bundle.dir}: the manifest's occupancy offsets (${fromManifest}) are not §12.3's (${levels.offset})`);
  return {uniforms, particles, nx, ny, nz, levels};
}

/** Runs the splat's passes and the occupancy grid on the device: {u32 (Uint32Array), f16 (Uint16Array, 4 halves a
 * voxel), occupancy (Uint32Array, every level)}. */
export async function runSplat(device, inp, {timer = null} = {}) {
  const {uniforms, particles, nx, ny, nz, levels} = inp;
  const n = particles.length / 3;
  const voxels = nx * ny * nz;
  const bufs = [];
  const keep = (b) => (bufs.push(b), b);
  const uniform = (data, label) => keep(buffer(device, data.byteLength, {data, label,
    usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST}));
  const params = uniform(uniforms, 'fluid params');
  const splatCounts = uniform(new Uint32Array([n, nx, ny, nz]), 'splat counts');
  const clearCounts = uniform(new Uint32Array([voxels, nx, ny, nz]), 'clear counts');
  const occCounts = uniform(new Uint32Array([levels.words, nx, ny, nz]), 'occupancy counts');
  const pos = keep(buffer(device, particles.byteLength, {data: particles, label: 'particles'}));
  const vol = keep(buffer(device, voxels * 4, {label: 'volume u32'}));
  const occ = keep(buffer(device, levels.words * 4, {label: 'occupancy'}));
  // The occupancy buffer starts non-zero so that the clear pass is exercised (and a missing one is seen).
  device.queue.writeBuffer(occ, 0, new Uint32Array(occ.size / 4).fill(0xA5A5A5A5));
  device.queue.writeBuffer(vol, 0, new Uint32Array(vol.size / 4).fill(0xA5A5A5A5));
  const tex = device.createTexture({size: [nx, ny, nz], dimension: '3d', format: 'rgba16float', label: 'density',
    usage: GPUTextureUsage.STORAGE_BINDING | GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_SRC});

  const enc = device.createCommandEncoder();
  const run = (label, pipe, entries, groups) => {
    const pass = timer ? timer.pass(enc, label) : enc.beginComputePass({label});
    pass.setPipeline(pipe);
    pass.setBindGroup(0, device.createBindGroup({layout: pipe.getBindGroupLayout(0),
      entries: Object.entries(entries).map(([b, r]) => ({binding: Number(b), resource: r.createView ? r.createView()
        : {buffer: r}}))}));
    pass.dispatchWorkgroups(...groups);
    pass.end();
  };
  const clearPipe = pipeline(device, 'fluid_splat_clear.wgsl');
  run('splat_clear', clearPipe, {0: clearCounts, 1: vol}, grid(Math.ceil(voxels / WG)));
  run('splat_particles', pipeline(device, 'fluid_splat.wgsl'), {0: params, 1: splatCounts, 2: pos, 3: vol},
    grid(Math.max(1, Math.ceil(n / WG))));
  run('splat_resolve', pipeline(device, 'fluid_resolve.wgsl'), {0: params, 1: clearCounts, 2: vol, 3: tex},
    [Math.ceil(nx / 8), Math.ceil(ny / 8), Math.ceil(nz / 4)]);
  run('occupancy_clear', pipeline(device, 'fluid_occupancy.wgsl', {entry: 'clear'}), {1: occCounts, 5: occ},
    grid(Math.ceil(levels.words / WG)));
  run('occupancy', pipeline(device, 'fluid_occupancy.wgsl'), {0: params, 1: splatCounts, 2: pos, 3: occ},
    grid(Math.max(1, Math.ceil(n / WG))));
  const mip = pipeline(device, 'fluid_occupancy.wgsl', {entry: 'mip'});
  for (let l = 0; l + 1 < levels.res.length; l++) {
    const lv = uniform(new Uint32Array([levels.res[l], levels.offset[l], levels.res[l + 1], levels.offset[l + 1]]),
      `level ${l + 1}`);
    const words = Math.ceil(levels.res[l + 1] ** 3 / 32);
    run('occupancy_mip', mip, {4: lv, 5: occ}, grid(Math.ceil(words / WG)));
  }
  // The texture's texels into a buffer (rows padded to 256 bytes, as copyTextureToBuffer requires).
  const rowBytes = Math.ceil((nx * 8) / 256) * 256;
  const texBuf = keep(buffer(device, rowBytes * ny * nz, {label: 'density copy'}));
  enc.copyTextureToBuffer({texture: tex}, {buffer: texBuf, bytesPerRow: rowBytes, rowsPerImage: ny}, [nx, ny, nz]);
  device.pushErrorScope('validation');
  let out;
  try {
    out = await readBack(device, enc, [vol, texBuf, occ], [voxels * 4, rowBytes * ny * nz, levels.words * 4]);
  } finally {
    const e = await device.popErrorScope();
    if (e) throw new Error(e.message.split('\n')[0]);
  }
  const padded = new Uint16Array(out[1]);
  const f16 = new Uint16Array(voxels * 4);
  for (let z = 0; z < nz; z++) for (let y = 0; y < ny; y++) {
    const from = (z * ny + y) * (rowBytes / 2);
    f16.set(padded.subarray(from, from + nx * 4), ((z * ny + y) * nx) * 4);
  }
  for (const b of bufs) b.destroy();
  return {u32: new Uint32Array(out[0]), f16, occupancy: new Uint32Array(out[2]), texture: tex};
}

/** The dump check-volume reads: volume_u32.npy u32 (nz, ny, nx), volume_f16.npy f16 (nz, ny, nx, 4) (the texture's
 * texels, density in R), occupancy.npy u32 (words,). */
export function writeSplatDump(dir, inp, s) {
  const {nx, ny, nz} = inp;
  writeNpy(path.join(dir, 'volume_u32.npy'), s.u32, [nz, ny, nx], '<u4');
  writeNpy(path.join(dir, 'volume_f16.npy'), s.f16, [nz, ny, nx, 4], '<f2');
  writeNpy(path.join(dir, 'occupancy.npy'), s.occupancy, [s.occupancy.length], '<u4');
}

export async function dump(ctx) {
  const bundle = new Bundle(path.join(ctx.dir, 'expected'));
  const inp = splatInputs(bundle);
  const s = await runSplat(ctx.device, inp, {timer: ctx.timer});
  writeSplatDump(ctx.dumpDir, inp, s);
  s.texture.destroy();
}

export function validate(ctx) {
  return {...check(ctx.rtoracle, 'check-volume', ['--expected', path.join(ctx.dir, 'expected'), '--gpu', ctx.dumpDir]),
    check: 'check-volume'};
}


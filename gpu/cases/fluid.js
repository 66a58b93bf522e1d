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
//   - workgroups of 256 invocations (the seed's 256x1x1 and 8x8x4): over compatibility mode's defaults
//     (maxComputeInvocationsPerWorkgroup 128, maxComputeWorkgroupSizeX 128); gpu/lib/device.js requests 256.
//   - the rgba16float store rounds toward zero (every voxel where that and nearest-even differ); check-volume admits
//     it unless --f16-rounding nearest. The H100 (Vulkan) truncates too.
//   - a linear sampler over the 3-D rgba16float texture with textureSampleLevel in a compute shader: allowed; the
//     weights are unquantized f32 (GPUs use 8 bits). copyTextureToBuffer and writeTexture of 3-D textures: allowed.
// docs/gpu.md ("Fluid volume") has the figures.
import {spawnSync} from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {buffer, bundledKernels, grid, pipeline, readBack} from '../lib/gpu.js';
import {writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';

export const family = 'fluid';

const WG = 256;

const fluidCase = (gen, res, extra = {}) => {
  // The smoothing radius: 1.8 voxels of the default bounds [-1, 1]^3 unless given (rtoracle splat's 0.05 is for 64^3).
  const radius = extra.radius || Number((3.6 / res).toFixed(3));
  const c = {family, gen, res, occupancy: extra.occupancy || 8, radius, rm: extra.rm || null};
  const bits = [gen, `r${res}`, `o${c.occupancy}`, `h${c.radius}`];
  if (c.rm) bits.push(`rm-${c.rm.width}x${c.rm.height}${c.rm.skip ? '-skip' : ''}${c.rm.chain ? '-chain' : ''}`);
  return {...c, id: `fluid/${bits.join('/')}`};
};

/** ci: the raymarch of dambreak:2000 at 24^3 voxels (8^3 occupancy), 48x36, with and without skipping, and the
 * splats of splash and the lattice at 24^3 and single at 16^3; full: also the splat of dambreak alone, raymarches of
 * splash, pool and single, and splats of pool, larger volumes and particle counts, other radii and occupancy
 * resolutions. --scenes: each generator spec named (rtoracle splat GENERATOR: dambreak:N, pool:N, splash:N, single,
 * lattice) at 24^3 voxels; the other scenes named are the other families'. */
export function list(opts) {
  if (opts.scenes)
    return opts.scenes.filter((g) => /^((dambreak|pool|splash):\d+|single|lattice)$/.test(g))
      .map((g) => fluidCase(g, 24));
  // A raymarch case checks its splat too (check-volume, then check-raymarch); the raymarch cases need
  // kernels/fluid_raymarch.wgsl (a --kernels directory may replace it, not remove it).
  // (rm.chain, the march on the device's own resolve, is listed nowhere: on llvmpipe, whose binary16 store
  // truncates, splash:8000's march then fails one certain pixel of 6,772 against the reference of the round-to-nearest
  // volume; dambreak:2000's passes. The reference marches the oracle's volume, and so do the listed cases.)
  const rm = (gen, res, w, h, skip, chain = false) => fluidCase(gen, res, {rm: {width: w, height: h, skip,
    ...(chain ? {chain} : {})}});
  const march = haveRaymarch() ? [rm('dambreak:2000', 24, 48, 36, true), rm('dambreak:2000', 24, 48, 36, false)]
    : [fluidCase('dambreak:2000', 24)];
  const ci = [...march, fluidCase('splash:1000', 24), fluidCase('single', 16), fluidCase('lattice', 24)];
  if (opts.subset === 'ci') return ci;
  const marchFull = haveRaymarch() ? [rm('splash:8000', 40, 96, 72, true), rm('splash:8000', 40, 96, 72, false),
    rm('pool:4000', 32, 80, 60, true), rm('single', 16, 32, 24, true), fluidCase('dambreak:2000', 24)] : [];
  return [...ci, ...marchFull, fluidCase('pool:4000', 32), fluidCase('dambreak:20000', 48, {occupancy: 16}),
    fluidCase('splash:8000', 40, {occupancy: 32}), fluidCase('pool:30000', 64, {occupancy: 32}),
    fluidCase('lattice', 33, {occupancy: 7}), fluidCase('single', 31, {occupancy: 5, radius: 0.3}),
    fluidCase('dambreak:5000', 32, {radius: 0.12})];
}

const RAYMARCH = 'fluid_raymarch.wgsl';
const haveRaymarch = () => bundledKernels().includes(RAYMARCH);

/** The oracle's splat bundle (the GPU's inputs and the volume and occupancy it must match), and for a raymarch case
 * its raymarch bundle (CASE/rm: rm_params.npy, the splat's volume and occupancy, the expected image, crossings and
 * step counts). */
export function prepare(ctx, c) {
  rtoracle(ctx.rtoracle, ['splat', c.gen, '--resolution', String(c.res), '--occupancy', String(c.occupancy),
    '--radius', String(c.radius), '-o', path.join(ctx.dir, 'expected')]);
  if (c.rm)
    rtoracle(ctx.rtoracle, ['raymarch', path.join(ctx.dir, 'expected'), '--width', String(c.rm.width), '--height',
      String(c.rm.height), ...(c.rm.skip ? [] : ['--no-skip']), '-o', path.join(ctx.dir, 'rm')]);
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
export function splatInputs(bundle, {particles: withParticles = true} = {}) {
  const uniforms = bundle.npy('fluid_params.npy').data;
  if (!(uniforms instanceof Float32Array) || uniforms.length !== 16)
    throw new Error(`${bundle.dir}: fluid_params.npy is not f32 (16,)`);
  const particles = withParticles ? bundle.npy('particles.npy').data : new Float32Array(0);
  if (!(particles instanceof Float32Array) || particles.length % 3)
    throw new Error(`${bundle.dir}: particles.npy is not f32 (N, 3)`);
  const [nx, ny, nz] = [uniforms[12], uniforms[13], uniforms[14]];
  const o = uniforms[15];
  for (const [name, v, hi] of [['res x', nx, 1024], ['res y', ny, 1024], ['res z', nz, 1024], ['occupancy', o, 1024]])
    if (!Number.isInteger(v) || v < 1 || v > hi) throw new Error(`${bundle.dir}: fluid_params.npy: ${name} ${v}`);
  if (nx * ny * nz * 8 > 128 * 1024 * 1024)
    throw new Error(`${bundle.dir}: ${nx}x${ny}x${nz} voxels (at most 128 MiB)`);
  const levels = occupancyLevels(o);
  // The manifest's occupancy section (levels, words, level_L_offset, level_L_res) must be §12.3's layout.
  const m = bundle.manifest.occupancy;
  if (m) {
    const listed = levels.res.map((r, l) => [m[`level_${l}_res`], m[`level_${l}_offset`]]);
    if (m.levels !== levels.res.length || m.words !== levels.words ||
        listed.some(([r, off], l) => r !== levels.res[l] || off !== levels.offset[l]))
      throw new Error(`${bundle.dir}: the manifest's occupancy levels are not §12.3's for ${o} cells (` +
        `${levels.res.length} levels, ${levels.words} words, offsets ${levels.offset})`);
  }
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

/** The raymarch (kernels/fluid_raymarch.wgsl, entry point main, one thread per pixel, 8x8 workgroups) of a raymarch
 * bundle. Its bindings (group 0): 0 rm_params.npy as a uniform block (rto_raymarch_uniforms, 256 bytes), 1 the density
 * volume (texture_3d<f32>, rgba16float: density in R), 2 its sampler (linear min/mag/mip filtering, clamp-to-edge),
 * 3 the occupancy words of every level (storage, read), 4 the image (array<vec4<f32>>, H*W), 5 the first crossing's
 * step per pixel (array<u32>, 0xFFFFFFFF: none), 6 the primary-march steps per pixel (array<u32>). The march runs
 * twice on the same texture: with the bundle's skip flag (rm_params[58]) (image, crossing, steps_skip) and with it
 * 0 (crossing_noskip, steps), so that check-raymarch compares skipping with not skipping on one device.
 * The texture is the bundle's volume_f16.npy uploaded as it is (the volume the reference marched): a device whose
 * resolve truncates binary16 (llvmpipe) would otherwise march another volume than the oracle's. */
/** A raymarch bundle's volume_f16.npy as the raymarch's density texture: rgba16float (nx, ny, nz), texels (density, 0,
 * 0, 1), uploaded as it is. */
export function densityTexture(device, rmBundle) {
  const {nx, ny, nz} = splatInputs(rmBundle, {particles: false});
  const vol = rmBundle.npy('volume_f16.npy').data;
  if (vol.length !== nx * ny * nz) throw new Error(`${rmBundle.dir}: volume_f16.npy holds ${vol.length} voxels`);
  const texels = new Uint16Array(nx * ny * nz * 4);
  for (let i = 0; i < vol.length; i++) texels.set([vol[i], 0, 0, 0x3C00], 4 * i);
  const tex = device.createTexture({size: [nx, ny, nz], dimension: '3d', format: 'rgba16float', label: 'density',
    usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST});
  device.queue.writeTexture({texture: tex}, texels, {bytesPerRow: 8 * nx, rowsPerImage: ny}, [nx, ny, nz]);
  return tex;
}

/** The raymarch's sampler: linear min/mag/mip filtering, clamp-to-edge on u, v and w. */
export function linearSampler(device) {
  return device.createSampler({magFilter: 'linear', minFilter: 'linear', mipmapFilter: 'linear',
    addressModeU: 'clamp-to-edge', addressModeV: 'clamp-to-edge', addressModeW: 'clamp-to-edge'});
}

export async function runRaymarch(device, rmBundle, {timer = null, texture = null} = {}) {
  const u = rmBundle.npy('rm_params.npy').data;
  if (!(u instanceof Float32Array) || u.length !== 64)
    throw new Error(`${rmBundle.dir}: rm_params.npy is not f32 (64,)`);
  const [W, H] = [u[56], u[57]];
  if (!Number.isInteger(W) || !Number.isInteger(H) || W < 1 || H < 1 || W * H > 4096 * 4096)
    throw new Error(`${rmBundle.dir}: rm_params.npy: ${W}x${H} pixels`);
  const occWords = rmBundle.words('occupancy.npy');
  const tex = texture || densityTexture(device, rmBundle);
  const sampler = linearSampler(device);
  const bufs = [];
  const keep = (b) => (bufs.push(b), b);
  const occ = keep(buffer(device, occWords.byteLength, {data: occWords, label: 'occupancy'}));
  const pipe = pipeline(device, RAYMARCH);
  const n = W * H;
  const enc = device.createCommandEncoder();
  const outs = [];
  for (const skip of [u[58], 0]) {
    const params = new Float32Array(u);
    params[58] = skip;
    const ub = keep(buffer(device, 256, {data: params, label: 'rm params',
      usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST}));
    const image = keep(buffer(device, n * 16, {label: 'image'}));
    const crossing = keep(buffer(device, n * 4, {label: 'crossing'}));
    const steps = keep(buffer(device, n * 4, {label: 'steps'}));
    const label = skip ? 'raymarch_skip' : 'raymarch';
    const pass = timer ? timer.pass(enc, label) : enc.beginComputePass({label});
    pass.setPipeline(pipe);
    pass.setBindGroup(0, device.createBindGroup({layout: pipe.getBindGroupLayout(0), entries: [
      {binding: 0, resource: {buffer: ub}}, {binding: 1, resource: tex.createView()}, {binding: 2, resource: sampler},
      {binding: 3, resource: {buffer: occ}}, {binding: 4, resource: {buffer: image}},
      {binding: 5, resource: {buffer: crossing}}, {binding: 6, resource: {buffer: steps}}]}));
    pass.dispatchWorkgroups(Math.ceil(W / 8), Math.ceil(H / 8));
    pass.end();
    outs.push(image, crossing, steps);
  }
  device.pushErrorScope('validation');
  let r;
  try {
    r = await readBack(device, enc, outs, [n * 16, n * 4, n * 4, n * 16, n * 4, n * 4]);
  } finally {
    const e = await device.popErrorScope();
    if (e) throw new Error(e.message.split('\n')[0]);
  }
  for (const b of bufs) b.destroy();
  if (!texture) tex.destroy();
  return {width: W, height: H, skip: u[58] !== 0, image: new Float32Array(r[0]), crossing: new Uint32Array(r[1]),
    steps_skip: new Uint32Array(r[2]), crossing_noskip: new Uint32Array(r[4]), steps: new Uint32Array(r[5])};
}

/** The dump check-raymarch reads: image.npy f32 (H, W, 4), crossing.npy u32 (H, W) (the skipping march where the
 * bundle skips), crossing_noskip.npy, steps.npy (the march without skipping), steps_skip.npy (with it). */
export function writeRaymarchDump(dir, r) {
  const {width: W, height: H} = r;
  writeNpy(path.join(dir, 'image.npy'), r.image, [H, W, 4], '<f4');
  writeNpy(path.join(dir, 'crossing.npy'), r.crossing, [H, W], '<u4');
  writeNpy(path.join(dir, 'steps.npy'), r.steps, [H, W], '<u4');
  if (r.skip) {
    writeNpy(path.join(dir, 'crossing_noskip.npy'), r.crossing_noskip, [H, W], '<u4');
    writeNpy(path.join(dir, 'steps_skip.npy'), r.steps_skip, [H, W], '<u4');
  }
}

export async function dump(ctx, c) {
  const bundle = new Bundle(path.join(ctx.dir, 'expected'));
  const inp = splatInputs(bundle);
  const s = await runSplat(ctx.device, inp, {timer: ctx.timer});
  writeSplatDump(ctx.dumpDir, inp, s);
  if (c.rm) {
    const rmDir = path.join(ctx.dumpDir, 'rm');
    fs.mkdirSync(rmDir, {recursive: true});
    // chain: the march samples the texture the device's own resolve wrote (the seed's chain), else the oracle's volume.
    writeRaymarchDump(rmDir, await runRaymarch(ctx.device, new Bundle(path.join(ctx.dir, 'rm')), {timer: ctx.timer,
      texture: c.rm.chain ? s.texture : null}));
  }
  s.texture.destroy();
}

/** check-volume on the splat's dump; for a raymarch case then check-raymarch on the march's (the first failure
 * counts). */
export function validate(ctx, c) {
  const v = {...check(ctx.rtoracle, 'check-volume', ['--expected', path.join(ctx.dir, 'expected'), '--gpu',
    ctx.dumpDir]), check: 'check-volume'};
  if (!v.pass || !c.rm) return v;
  return {...checkText(ctx.rtoracle, 'check-raymarch', ['--expected', path.join(ctx.dir, 'rm'), '--gpu',
    path.join(ctx.dumpDir, 'rm')]), check: 'check-raymarch'};
}

/** A check without --json (check-raymarch): {pass, status, diagnosis, fault} from its text, whose verdict line is
 * "check-raymarch: FAIL FAULT[ at pixel (x, y)]: DETAIL" (status 1) or one error line (status 2). */
function checkText(bin, command, args) {
  const r = spawnSync(bin, [command, ...args], {encoding: 'utf8', maxBuffer: 64 << 20});
  if (r.error) throw new Error(`${bin}: ${r.error.message}`);
  const line = (r.stdout || '').split('\n').find((l) => / FAIL /.test(l)) || (r.stderr || r.stdout || '').trim()
    .split('\n')[0];
  const m = / FAIL ([a-z-]+)/.exec(line);
  return {pass: r.status === 0, status: r.status, diagnosis: r.status === 0 ? '' : line.replace(/^[a-z-]+: FAIL /, ''),
    fault: r.status === 1 && m ? m[1] : null};
}


// The visibility buffer of seed 004 on the GPU (DESIGN.md §11): the visibility pass (kernels/vb_visibility.wgsl, a
// render pipeline, 1x or 4x MSAA), the planes copied to a buffer (kernels/vb_dump.wgsl) and the material pass
// (kernels/vb_material.wgsl), from a vbuffer bundle's meshes, instances, camera and parameters; the dump's .npy files.
import path from 'node:path';
import {buffer, pipeline, readBack, shaderModule} from './gpu.js';
import {writeNpy} from './npy.js';

const INSTANCE_WORDS = 32;
const INSTANCE_BLAS = 24;
const MESH_WORDS = 4;
export const MATERIALS = {normals: 0, lambert: 1, unlit: 2};
/** Texture slots of vb_material.wgsl (bindings 7 to 10). */
const TEXTURE_SLOTS = 4;
const NONE = 0xFFFFFFFF;
const CLEAR0 = {r: 0, g: 0, b: 0, a: 0};
/** The colour targets of the visibility pass, in location order, with their clear values: the G-buffer of §11.4, and
 * the split one of compatibility mode at 4x (vb_visibility.wgsl's fs_split: it multisamples neither rgba16uint nor
 * rgba16float). */
const TARGETS = [
  {name: 'visibility', format: 'rgba16uint', clear: {r: 0xFFFF, g: 0xFFFF, b: 0xFFFF, a: 0xFFFF}},
  {name: 'barycentric', format: 'rg16float', clear: CLEAR0},
  {name: 'normal', format: 'rgba16float', clear: CLEAR0},
  {name: 'derivatives', format: 'rgba16float', clear: CLEAR0},
];
const SPLIT_TARGETS = [
  {name: 'visibility prim', format: 'rgba8unorm', clear: {r: 1, g: 1, b: 1, a: 1}},
  {name: 'visibility instance', format: 'rgba8unorm', clear: {r: 1, g: 1, b: 1, a: 1}},
  {name: 'barycentric', format: 'rg16float', clear: CLEAR0},
  {name: 'normal xy', format: 'rg16float', clear: CLEAR0},
  {name: 'normal zw', format: 'rg16float', clear: CLEAR0},
  {name: 'ddx', format: 'rg16float', clear: CLEAR0},
  {name: 'ddy', format: 'rg16float', clear: CLEAR0},
];

/** How the passes run on a device at a sample count: the targets, the fragment entry point and vb_dump.wgsl's entry
 * point and first texture binding. */
export function vbufferMode(device, samples) {
  if (fineDerivatives(device))
    return {targets: TARGETS, fragment: 'fs_main', dump: samples > 1 ? 'main_ms' : 'main_1x',
      first: samples > 1 ? 2 : 7};
  if (samples === 1) return {targets: TARGETS, fragment: 'fs_compat', dump: 'main_1x', first: 7};
  return {targets: SPLIT_TARGETS, fragment: 'fs_split', dump: 'main_split', first: 12};
}

/** The geometry words vb_visibility.wgsl pulls vertices from: MESH_WORDS per mesh (triangles, positions at, indices
 * at, 0), then each mesh's positions and indices; and the triangle count of every mesh. */
function packGeometry(bundle, meshes) {
  const parts = [];
  let at = meshes * MESH_WORDS;
  const table = new Uint32Array(meshes * MESH_WORDS);
  const triangles = [];
  for (let m = 0; m < meshes; m++) {
    const pos = bundle.words(`mesh_${m}_positions.npy`);
    const idx = bundle.words(`mesh_${m}_indices.npy`);
    triangles.push(idx.length / 3);
    table.set([idx.length / 3, at, at + pos.length, 0], m * MESH_WORDS);
    parts.push([at, pos], [at + pos.length, idx]);
    at += pos.length + idx.length;
  }
  const words = new Uint32Array(at);
  words.set(table, 0);
  for (const [off, w] of parts) words.set(w, off);
  return {words, triangles};
}

/** unlit's inputs (DESIGN.md §11.5): vb_material.wgsl's tex_meshes words (per mesh: texture slot or NONE, where its
 * UVs start, where its indices start, 0; then each sampling mesh's mesh_M_uvs.npy and mesh_M_indices.npy words) and
 * one rgba16float texture per vb_texture_T.npy, its levels uploaded as the bundle holds them (binary16, the oracle's
 * box-filtered chain: the GPU generates no level itself). A bundle without vb_mesh_textures.npy samples none. */
function unlitInputs(device, bundle, meshes) {
  const table = new Uint32Array(4 * meshes).fill(0);
  const parts = [];
  let at = 4 * meshes;
  const mt = bundle.has('vb_mesh_textures.npy') ? bundle.npy('vb_mesh_textures.npy').data : new Int32Array(meshes).fill(-1);
  const sizes = bundle.has('vb_textures.npy') ? bundle.npy('vb_textures.npy').data : new Uint32Array(0);
  const count = sizes.length / 3;
  if (count > TEXTURE_SLOTS)
    throw new Error(`${bundle.dir}: ${count} textures (vb_material.wgsl binds ${TEXTURE_SLOTS})`);
  for (let m = 0; m < meshes; m++) {
    if (mt[m] < 0) {
      table.set([NONE, 0, 0, 0], 4 * m);
      continue;
    }
    const uv = bundle.words(`mesh_${m}_uvs.npy`);
    const idx = bundle.words(`mesh_${m}_indices.npy`);
    table.set([mt[m], at, at + uv.length, 0], 4 * m);
    parts.push([at, uv], [at + uv.length, idx]);
    at += uv.length + idx.length;
  }
  const words = new Uint32Array(Math.max(at, 4));
  words.set(table, 0);
  for (const [off, w] of parts) words.set(w, off);
  const textures = [];
  for (let t = 0; t < TEXTURE_SLOTS; t++) {
    const [w0, h0, levels] = t < count ? [sizes[3 * t], sizes[3 * t + 1], sizes[3 * t + 2]] : [1, 1, 1];
    const tex = device.createTexture({size: [w0, h0], format: 'rgba16float', mipLevelCount: levels,
      usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST, label: `texture ${t}`});
    const bits = t < count ? bundle.npy(`vb_texture_${t}.npy`).data : new Uint16Array(4);
    let off = 0;
    for (let l = 0; l < levels; l++) {
      const w = Math.max(1, w0 >> l), h = Math.max(1, h0 >> l);
      device.queue.writeTexture({texture: tex, mipLevel: l}, bits.subarray(off, off + 4 * w * h),
        {bytesPerRow: 8 * w, rowsPerImage: h}, [w, h]);
      off += 4 * w * h;
    }
    if (off !== bits.length) throw new Error(`${bundle.dir}: vb_texture_${t}.npy holds ${bits.length / 4} texels, ` +
      `its ${levels} levels ${off / 4}`);
    textures.push(tex);
  }
  const sampler = device.createSampler({addressModeU: 'repeat', addressModeV: 'repeat', magFilter: 'linear',
    minFilter: 'linear', mipmapFilter: 'linear'});
  return {words, textures, sampler};
}

/** Whether the device has WGSL's fine derivative built-ins and multisamples rgba16uint and rgba16float: a core device
 * (compatibility mode has no 'core-features-and-limits'). */
export function fineDerivatives(device) {
  return device.features.has('core-features-and-limits');
}

/** The parameters of a vbuffer bundle's manifest section (width, height, samples, material, threshold_normal,
 * threshold_depth, threshold_sample_depth, sun_x, sun_y, sun_z, ambient) as {width, height, samples, material,
 * thresholds: {normal, depth, sample_depth}, sun: [x, y, z], ambient}. */
export function vbufferParams(bundle) {
  const m = bundle.manifest.vbuffer;
  if (!m) throw new Error(`${bundle.dir}: the manifest has no vbuffer section`);
  const v = {width: m.width, height: m.height, samples: m.samples, material: m.material, ambient: m.ambient,
    thresholds: {normal: m.threshold_normal, depth: m.threshold_depth, sample_depth: m.threshold_sample_depth},
    sun: [m.sun_x, m.sun_y, m.sun_z]};
  const missing = Object.entries({...v, ...v.thresholds, sun: v.sun[0] ?? v.sun[1] ?? v.sun[2]})
    .filter(([, x]) => x === undefined).map(([k]) => k);
  if (missing.length) throw new Error(`${bundle.dir}: the manifest's vbuffer section lacks ${missing.join(', ')}`);
  if (!(v.material in MATERIALS))
    throw new Error(`${bundle.dir}: material '${v.material}' (the GPU pass has ${Object.keys(MATERIALS).join(', ')})`);
  if (v.samples !== 1 && v.samples !== 4) throw new Error(`${bundle.dir}: ${v.samples} samples (1 or 4)`);
  return v;
}

/** Renders a vbuffer bundle: {width, height, samples, planes (Uint32Array, vb_dump.wgsl's layout), image (2 words a
 * pixel), mask (1 word a pixel)}. */
export async function renderVbuffer(device, bundle, {timer = null} = {}) {
  const v = vbufferParams(bundle);
  const {width, height, samples} = v;
  const mode = vbufferMode(device, samples);
  // A validation error (a format or limit the device lacks) fails the case with its message.
  device.pushErrorScope('validation');
  try {
    return await passes(device, bundle, v, mode, timer);
  } finally {
    const e = await device.popErrorScope();
    if (e) throw new Error(`${e.message.split('\n')[0]} (${mode.fragment}, ${samples}x)`);
  }
}

async function passes(device, bundle, v, mode, timer) {
  const {width, height, samples} = v;
  const TARGETS = mode.targets;
  const n = width * height * samples;
  const camera = bundle.npy('vb_camera.npy').data;
  const instances = bundle.words('instances.npy');
  const meshes = bundle.manifest.counts?.meshes;
  if (!Number.isInteger(meshes)) throw new Error(`${bundle.dir}: the manifest has no mesh count`);
  const geo = packGeometry(bundle, meshes);
  const bufs = [];
  const keep = (b) => (bufs.push(b), b);
  const uniform = (data) => keep(buffer(device, data.byteLength, {data,
    usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST}));
  const cameraBuf = uniform(camera);
  const instBuf = keep(buffer(device, instances.byteLength, {data: instances, label: 'instances'}));
  const geoBuf = keep(buffer(device, geo.words.byteLength, {data: geo.words, label: 'geometry'}));

  const usage = GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.TEXTURE_BINDING;
  const size = [width, height];
  const textures = TARGETS.map((t) => device.createTexture({size, format: t.format, sampleCount: samples, usage,
    label: t.name}));
  const depth = device.createTexture({size, format: 'depth24plus', sampleCount: samples, usage, label: 'depth'});

  const module = shaderModule(device, 'vb_visibility.wgsl');
  const render = device.createRenderPipeline({layout: 'auto', label: 'vb_visibility.wgsl:vs_main',
    vertex: {module, entryPoint: 'vs_main'},
    fragment: {module, entryPoint: mode.fragment, targets: TARGETS.map((t) => ({format: t.format}))},
    primitive: {topology: 'triangle-list', cullMode: 'none'},
    depthStencil: {format: 'depth24plus', depthWriteEnabled: true, depthCompare: 'less'},
    multisample: {count: samples}});
  const enc = device.createCommandEncoder();
  const rp = enc.beginRenderPass({label: 'vb_visibility',
    colorAttachments: TARGETS.map((t, i) => ({view: textures[i].createView(), clearValue: t.clear, loadOp: 'clear',
      storeOp: 'store'})),
    depthStencilAttachment: {view: depth.createView(), depthClearValue: 1.0, depthLoadOp: 'clear',
      depthStoreOp: 'store'},
    ...(timer && timer.on ? {timestampWrites: timer.writes('vb_visibility')} : {})});
  rp.setPipeline(render);
  rp.setBindGroup(0, device.createBindGroup({layout: render.getBindGroupLayout(0), entries: [
    {binding: 0, resource: {buffer: cameraBuf}}, {binding: 1, resource: {buffer: instBuf}},
    {binding: 2, resource: {buffer: geoBuf}}]}));
  // One draw per instance, in instance order; firstInstance carries the instance index to instance_index.
  for (let i = 0; i < instances.length / INSTANCE_WORDS; i++) {
    const t = geo.triangles[instances[i * INSTANCE_WORDS + INSTANCE_BLAS]];
    if (t === undefined) throw new Error(`instance ${i}: mesh ${instances[i * INSTANCE_WORDS + INSTANCE_BLAS]} ` +
      `of ${meshes}`);
    if (t > 0) rp.draw(3 * t, 1, 0, i);
  }
  rp.end();

  // The planes into one buffer of words (vb_dump.wgsl).
  const planes = keep(buffer(device, 8 * n * 4, {label: 'planes'}));
  const dumpParams = uniform(new Uint32Array([width, height, samples, n]));
  const ms = samples > 1;
  const first = mode.first;
  // An explicit layout: the depth texture binds as unfilterable-float (layout 'auto' would ask a filterable one at 1x).
  const dumpLayout = device.createBindGroupLayout({label: 'vb_dump', entries: [
    {binding: 0, visibility: GPUShaderStage.COMPUTE, buffer: {type: 'uniform'}},
    {binding: 1, visibility: GPUShaderStage.COMPUTE, buffer: {type: 'storage'}},
    ...[...TARGETS.map((t) => t.format), 'depth24plus'].map((f, i) => ({binding: first + i,
      visibility: GPUShaderStage.COMPUTE, texture: {sampleType: f === 'rgba16uint' ? 'uint' : 'unfilterable-float',
        multisampled: ms}}))]});
  const dumpPipe = device.createComputePipeline({label: 'vb_dump.wgsl', compute: {module: shaderModule(device,
    'vb_dump.wgsl'), entryPoint: mode.dump},
    layout: device.createPipelineLayout({bindGroupLayouts: [dumpLayout]})});
  const groups = [Math.ceil(width / 8), Math.ceil(height / 8)];
  const dp = timer ? timer.pass(enc, 'vb_dump') : enc.beginComputePass({label: 'vb_dump'});
  dp.setPipeline(dumpPipe);
  dp.setBindGroup(0, device.createBindGroup({layout: dumpLayout, entries: [
    {binding: 0, resource: {buffer: dumpParams}}, {binding: 1, resource: {buffer: planes}},
    ...[...textures, depth].map((t, i) => ({binding: first + i, resource: t.createView()}))]}));
  dp.dispatchWorkgroups(...groups);
  dp.end();

  // The material pass on those planes.
  const params = new Float32Array(32);
  params.set(camera.subarray(16, 32), 0);
  params.set([...v.sun, v.ambient], 16);
  params.set([v.thresholds.normal, v.thresholds.depth, v.thresholds.sample_depth, 0], 20);
  new Uint32Array(params.buffer).set([width, height, samples, n, MATERIALS[v.material], 0, 0, 0], 24);
  const matParams = uniform(params);
  const image = keep(buffer(device, width * height * 8, {label: 'image'}));
  const mask = keep(buffer(device, width * height * 4, {label: 'edge mask'}));
  // Each mesh's base colour (vb_base_colors.npy; white where the bundle has none).
  const colors = bundle.has('vb_base_colors.npy') ? bundle.npy('vb_base_colors.npy').data
    : new Float32Array(4 * meshes).fill(1);
  if (colors.length !== 4 * meshes) throw new Error(`${bundle.dir}: ${colors.length / 4} base colours, ${meshes} meshes`);
  const colorBuf = keep(buffer(device, colors.byteLength, {data: colors, label: 'base colours'}));
  const tx = unlitInputs(device, bundle, meshes);
  const texMeshBuf = keep(buffer(device, tx.words.byteLength, {data: tx.words, label: 'texture meshes'}));
  const matPipe = pipeline(device, 'vb_material.wgsl');
  const mp = timer ? timer.pass(enc, 'vb_material') : enc.beginComputePass({label: 'vb_material'});
  mp.setPipeline(matPipe);
  mp.setBindGroup(0, device.createBindGroup({layout: matPipe.getBindGroupLayout(0), entries: [
    {binding: 0, resource: {buffer: matParams}}, {binding: 1, resource: {buffer: planes}},
    {binding: 2, resource: {buffer: image}}, {binding: 3, resource: {buffer: mask}},
    {binding: 4, resource: {buffer: instBuf}}, {binding: 5, resource: {buffer: colorBuf}},
    {binding: 6, resource: {buffer: texMeshBuf}},
    ...tx.textures.map((t, i) => ({binding: 7 + i, resource: t.createView()})),
    {binding: 11, resource: tx.sampler}]}));
  mp.dispatchWorkgroups(...groups);
  mp.end();

  const [p, img, m] = await readBack(device, enc, [planes, image, mask], [8 * n * 4, width * height * 8,
    width * height * 4]);
  for (const b of bufs) b.destroy();
  for (const t of [...textures, depth, ...tx.textures]) t.destroy();
  return {width, height, samples, planes: new Uint32Array(p), image: new Uint32Array(img), mask: new Uint32Array(m)};
}

/** The dump's files (DESIGN.md §11.4, §11.5): vb_visibility.npy u16 (H, W, S, 4), vb_barycentric.npy f16 (H, W, S, 2),
 * vb_normal.npy and vb_derivatives.npy f16 (H, W, S, 4), vb_depth.npy f32 (H, W, S), vb_edge_mask.npy u8 (H, W),
 * vb_image.npy f16 (H, W, 4). */
export function writeVbufferDump(dir, vb) {
  const {width: w, height: h, samples: s, planes} = vb;
  const n = w * h * s;
  const halves = (from, words) => new Uint16Array(planes.buffer, from * 4, words * 2);
  writeNpy(path.join(dir, 'vb_visibility.npy'), halves(0, 2 * n), [h, w, s, 4], '<u2');
  writeNpy(path.join(dir, 'vb_barycentric.npy'), halves(2 * n, n), [h, w, s, 2], '<f2');
  writeNpy(path.join(dir, 'vb_normal.npy'), halves(3 * n, 2 * n), [h, w, s, 4], '<f2');
  writeNpy(path.join(dir, 'vb_derivatives.npy'), halves(5 * n, 2 * n), [h, w, s, 4], '<f2');
  writeNpy(path.join(dir, 'vb_depth.npy'), new Float32Array(planes.buffer, 7 * n * 4, n), [h, w, s]);
  writeNpy(path.join(dir, 'vb_edge_mask.npy'), Uint8Array.from(vb.mask), [h, w], '|u1'); // NumPy's name for u8
  writeNpy(path.join(dir, 'vb_image.npy'), new Uint16Array(vb.image.buffer, 0, w * h * 4), [h, w, 4], '<f2');
}

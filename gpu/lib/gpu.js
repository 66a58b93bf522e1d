// Small WebGPU helpers shared by every kernel family: WGSL modules with #include, buffers, read-back.
import fs from 'node:fs';

import path from 'node:path';

const KERNELS = path.join(path.dirname(new URL(import.meta.url).pathname), '..', 'kernels');
let overrides = process.env.RTO_GPU_KERNELS || null;

/** The names of the bundled kernels (gpu/kernels/*.wgsl), sorted. */
export function bundledKernels() {
  return fs.readdirSync(KERNELS).filter((f) => f.endsWith('.wgsl')).sort();
}

/** A directory whose .wgsl files replace the bundled kernels of the same name (gpu/run --kernels DIR). Every .wgsl
 * file there must name a bundled kernel: returns the sorted names it replaces, or throws naming the first unknown
 * one and the names known (a misnamed file would otherwise be ignored and the run pass on the bundled kernel). */
export function setKernelDir(dir) {
  const known = bundledKernels();
  const mine = fs.readdirSync(dir).filter((f) => f.endsWith('.wgsl')).sort();
  const unknown = mine.filter((f) => !known.includes(f));
  if (unknown.length)
    throw new Error(`--kernels ${dir}: ${unknown.join(', ')} ${unknown.length > 1 ? 'name' : 'names'} no bundled ` +
      `kernel; the kernels are ${known.join(', ')}`);
  if (!mine.length) throw new Error(`--kernels ${dir}: no .wgsl file there`);
  overrides = dir;
  return mine;
}

function kernelPath(name) {
  if (overrides && fs.existsSync(path.join(overrides, name))) return path.join(overrides, name);
  return path.join(KERNELS, name);
}

/** The WGSL text of kernels/FILE (or the override directory's) with every line `// #include "other.wgsl"` replaced
 * by that file (once each), after a `const NAME = value;` line for every entry of defines (booleans as they are,
 * integers as u32, other values as written), which a kernel tests like any constant. With the source of each line:
 * {code, origin}, origin[i] = [path, line] of line i + 1 (the defines: ['(defines)', k]). */
function expandWgsl(file, defines) {
  const seen = new Set();
  const lines = [], origin = [];
  const expand = (name) => {
    if (seen.has(name)) return;
    seen.add(name);
    const src = kernelPath(name);
    fs.readFileSync(src, 'utf8').split('\n').forEach((line, i) => {
      const inc = /^\/\/ #include "([^"]+)"$/.exec(line);
      if (inc) return expand(inc[1]);
      lines.push(line);
      origin.push([src, i + 1]);
    });
  };
  Object.entries(defines).forEach(([k, v], i) => {
    lines.push(`const ${k} = ${typeof v === 'boolean' ? v : typeof v === 'number' && Number.isInteger(v)
      ? `${v >>> 0}u` : v};`);
    origin.push(['(defines)', i + 1]);
  });
  expand(file);
  return {code: lines.join('\n'), origin};
}

export function wgsl(file, defines = {}) {
  return expandWgsl(file, defines).code;
}

/** The line origins of every module made by pipeline(), by label (the kernel's file name). */
const origins = new Map();

/** The shader module of kernels/FILE, labelled with the file name (its line origins kept for shaderError). */
export function shaderModule(device, file, defines = {}) {
  const {code, origin} = expandWgsl(file, defines);
  origins.set(file, origin);
  return device.createShaderModule({code, label: file});
}

/** A compute pipeline for kernels/FILE (entry point `entry`, layout 'auto'). A WGSL error surfaces as the device's
 * uncaptured error, which shaderError() turns into one line. */
export function pipeline(device, file, {entry = 'main', defines = {}} = {}) {
  const module = shaderModule(device, file, defines);
  return device.createComputePipeline({layout: 'auto', compute: {module, entryPoint: entry},
    label: `${file}:${entry}`});
}

/** Whether a device error is about a kernel's source or its pipeline (a setup error, not a data fault), and then one
 * line naming the file and line of the first WGSL error: "FILE:LINE:COL: error: ..."; null for other errors. */
export function shaderError(message) {
  const label = /(?:ShaderModuleDescriptor|ComputePipelineDescriptor|RenderPipelineDescriptor) ""([^":]+)(?::[^"]*)?""/.exec(message);
  const wgslErr = /(?:^|: ):(\d+):(\d+) (error: .*)$/m.exec(message);
  if (wgslErr) {
    const origin = label && origins.get(label[1]);
    const at = origin && origin[Number(wgslErr[1]) - 1];
    const where = at ? `${at[0]}:${at[1]}:${wgslErr[2]}` : `${label ? label[1] : 'a kernel'}:${wgslErr[1]}:${wgslErr[2]}`;
    return `${where}: ${wgslErr[3]}`;
  }
  if (label || /CreateShaderModule|CreateComputePipeline|CreateRenderPipeline|Invalid ShaderModule/.test(message))
    return `${label ? label[1] : 'a kernel'}: ${message.split('\n').find((l) => l.trim()) || 'invalid'}`;
  return null;
}

/** A dispatch of `groups` workgroups as [x, y]: WebGPU allows at most 65,535 per dimension (the default
 * maxComputeWorkgroupsPerDimension), so larger counts take rows of 32,768. A kernel reads its linear workgroup as
 * wg.x + wg.y * nwg.x (num_workgroups) and returns early past the count. */
export function grid(groups) {
  if (groups <= 65535) return [groups, 1];
  return [32768, Math.ceil(groups / 32768)];
}

export const STORAGE = () => GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC | GPUBufferUsage.COPY_DST;

/** A storage buffer of at least `bytes` (rounded up to 16, at least 16), optionally filled from a typed array. */
export function buffer(device, bytes, {data = null, usage = STORAGE(), label} = {}) {
  const size = Math.max(16, Math.ceil(Math.max(bytes, data ? data.byteLength : 0) / 16) * 16);
  const buf = device.createBuffer({size, usage, label});
  if (data) device.queue.writeBuffer(buf, 0, data.buffer, data.byteOffset, data.byteLength);
  return buf;
}

/** A bind group for group `group` of a pipeline from a list of buffers (binding i = buffers[i]) or
 * {binding: buffer | {buffer, offset, size}} entries. */
export function bind(device, pipe, group, buffers) {
  const entries = Array.isArray(buffers) ? buffers.map((b, i) => [i, b]) : Object.entries(buffers);
  return device.createBindGroup({layout: pipe.getBindGroupLayout(group), entries: entries.map(([i, b]) =>
    ({binding: Number(i), resource: b.buffer ? b : {buffer: b}}))});
}

/** Submits enc (if given) and resolves when the queue is idle. Dawn's callbacks are not libuv handles, so an interval
 * keeps Node's event loop alive meanwhile. */
export async function settle(device, enc = null) {
  if (enc) device.queue.submit([enc.finish()]);
  const alive = setInterval(() => {}, 5);
  try {
    await device.queue.onSubmittedWorkDone();
  } finally {
    clearInterval(alive);
  }
}

/** Copies the first `bytes` of each buffer out (finishing enc, or a fresh encoder): an array of ArrayBuffers. */
export async function readBack(device, enc, bufs, bytes) {
  const list = Array.isArray(bufs) ? bufs : [bufs];
  const sizes = Array.isArray(bytes) ? bytes : list.map((b) => (bytes === undefined ? b.size : bytes));
  enc = enc || device.createCommandEncoder();
  const reads = list.map((b, i) => {
    const size = Math.max(16, Math.ceil(sizes[i] / 4) * 4);
    const r = device.createBuffer({size, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST});
    if (sizes[i] > 0) enc.copyBufferToBuffer(b, 0, r, 0, Math.ceil(sizes[i] / 4) * 4);
    return r;
  });
  device.queue.submit([enc.finish()]);
  const alive = setInterval(() => {}, 5);
  try {
    await Promise.all(reads.map((r) => r.mapAsync(GPUMapMode.READ)));
  } finally {
    clearInterval(alive);
  }
  const out = reads.map((r, i) => {
    const copy = r.getMappedRange().slice(0, sizes[i]);
    r.unmap();
    r.destroy();
    return copy;
  });
  return Array.isArray(bufs) ? out : out[0];
}

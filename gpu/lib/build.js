// The TLAS build on a device (DESIGN.md §3 and §5, docs/gpu.md "TLAS build"): instance world boxes from the BLAS
// roots, centroid bounds, Morton keys, the bitonic sort (lib/sort.js) and the sweep tree, all in one command
// encoder; the keys, sorted keys and nodes stay on the device between the stages, as in a renderer's build.
import {bind, buffer, pipeline, readBack} from './gpu.js';
import {encodeBitonic, padded} from './sort.js';

const WG = 64;
const NODE_WORDS = 8; // TlasNode, 32 bytes
const BLAS_NODE_WORDS = 16; // BlasNode, 64 bytes
export const MAX_INSTANCES = 65536; // a TLAS key holds the instance index in 16 bits (§3)

/** What the GPU uploads from a build bundle: the instance records, and per mesh where its object box lies in one
 * array of BLAS words: the BLAS nodes of a mesh of 2 or more triangles (the box is its root's two child boxes), the
 * single triangle's box of a one-triangle mesh (whose BLAS has no internal node), nothing for an empty mesh.
 * meshTriangles is the host's count per mesh, which fixes how many instances get a key. */
export function buildInputs(bundle) {
  const count = bundle.manifest.counts.meshes;
  const meshes = new Uint32Array(2 * Math.max(1, count));
  const meshTriangles = [];
  const parts = [];
  let at = 0;
  for (let m = 0; m < count; m++) {
    const triangles = bundle.manifest[`blas_${m}`].triangles;
    const words = triangles >= 2 ? bundle.words(`blas_${m}_nodes.npy`)
      : triangles === 1 ? bundle.words(`blas_${m}_prim_aabbs.npy`) : new Uint32Array(0);
    if (triangles >= 2 && words.length !== (triangles - 1) * BLAS_NODE_WORDS)
      throw new Error(`blas_${m}_nodes.npy: ${words.length} words for ${triangles} triangles`);
    meshes.set([at, triangles], 2 * m);
    meshTriangles.push(triangles);
    parts.push(words);
    at += words.length;
  }
  const blas = new Uint32Array(Math.max(1, at));
  parts.reduce((o, w) => (blas.set(w, o), o + w.length), 0);
  const instances = bundle.words('instances.npy');
  return {instances, count: instances.length / 32, meshes, blas, meshTriangles};
}

/** device.popErrorScope(), keeping Node's event loop alive meanwhile as settle() does. */
async function popErrorScope(device) {
  const alive = setInterval(() => {}, 5);
  try {
    return await device.popErrorScope();
  } finally {
    clearInterval(alive);
  }
}

/** One 16-byte parameter record per dispatch, 256 bytes apart (the uniform offset alignment). */
function paramBuffer(device, records) {
  const words = new Uint32Array(64 * records.length);
  records.forEach((r, i) => words.set(r, 64 * i));
  return buffer(device, words.byteLength, {data: words, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST});
}

const slice = (buf, i) => ({buffer: buf, offset: 256 * i, size: 16});

function dispatch(device, enc, timer, label, pipe, entries, threads) {
  if (!threads) return; // no instances: nothing to run (the buffers' single records are never read)
  const pass = timer ? timer.pass(enc, label) : enc.beginComputePass({label});
  pass.setPipeline(pipe);
  pass.setBindGroup(0, bind(device, pipe, 0, entries));
  pass.dispatchWorkgroups(Math.ceil(threads / WG));
  pass.end();
}

/** Runs the build over buildInputs(bundle): {keys: Uint32Array (instances; key in instance order, the sentinel
 * for an instance of an empty BLAS), sorted: Uint32Array (n_padded), nodes: Uint32Array (nodes x 8 words),
 * nPadded, keyed}. timer labels the passes instance_boxes, centroid_bounds, morton, bitonic_pass, tlas_leaves and
 * tlas_build (one per level). */
export async function buildTlas(device, input, {timer = null} = {}) {
  const n = input.count;
  if (n > MAX_INSTANCES) throw new Error(`${n} instances: a TLAS key indexes at most ${MAX_INSTANCES}`);
  const keyed = [...Array(n).keys()].filter((i) => input.meshTriangles[input.instances[32 * i + 24]] > 0).length;
  // The sort buffer has a slot per instance (an unkeyed one holds a sentinel), so the keys need no compaction: the
  // keyed ones sort to the front, and the tree reads the first n_padded slots.
  const slots = padded(Math.max(1, n));
  const nPadded = keyed ? padded(keyed) : 0;
  const leaves = Math.max(1, nPadded); // no keyed instance: one EMPTY root (the sentinel of slot 0)
  const nodeCount = 2 * leaves - 1;
  const depth = Math.log2(leaves);

  const bufs = { // at least one record each: a binding holds a whole struct even when there are no instances
    instances: buffer(device, 128 * Math.max(1, n), {data: input.instances}),
    meshes: buffer(device, input.meshes.byteLength, {data: input.meshes}),
    blas: buffer(device, input.blas.byteLength, {data: input.blas}),
    boxes: buffer(device, 32 * Math.max(1, n)),
    bounds: buffer(device, 32),
    keys: buffer(device, 4 * slots),
    keysDump: buffer(device, 4 * n),
    nodes: buffer(device, 4 * NODE_WORDS * nodeCount),
  };
  const levels = [...Array(depth).keys()].reverse().map((d) => [(1 << d) - 1, 1 << d]);
  const params = paramBuffer(device, [[n, slots, 0, 0], [leaves - 1, leaves, 0, 0], ...levels.map(([f, c]) =>
    [f, c, 0, 0])]);

  device.pushErrorScope('validation'); // a bad binding would otherwise leave the dumps silently unwritten
  const enc = device.createCommandEncoder();
  const morton = (entry) => pipeline(device, 'morton.wgsl', {entry});
  dispatch(device, enc, timer, 'instance_boxes', morton('instance_boxes'),
    {0: slice(params, 0), 1: bufs.instances, 2: bufs.meshes, 3: bufs.blas, 4: bufs.boxes}, n);
  dispatch(device, enc, timer, 'centroid_bounds', morton('centroid_bounds'),
    {0: slice(params, 0), 4: bufs.boxes, 5: bufs.bounds}, WG); // one workgroup reduces them all
  dispatch(device, enc, timer, 'morton', morton('morton_keys'),
    {0: slice(params, 0), 4: bufs.boxes, 5: bufs.bounds, 6: bufs.keys}, slots);
  if (n) enc.copyBufferToBuffer(bufs.keys, 0, bufs.keysDump, 0, 4 * n); // the keys in instance order, before sorting
  const sortParams = encodeBitonic(device, enc, bufs.keys, slots, {timer});
  const sweep = (entry) => pipeline(device, 'tlas_sweep.wgsl', {entry});
  dispatch(device, enc, timer, 'tlas_leaves', sweep('leaves'),
    {0: slice(params, 1), 1: bufs.nodes, 2: bufs.keys, 3: bufs.boxes}, leaves);
  const level = sweep('level');
  levels.forEach(([, count], i) => dispatch(device, enc, timer, 'tlas_build', level,
    {0: slice(params, 2 + i), 1: bufs.nodes}, count));

  const [keys, sorted, nodes] = await readBack(device, enc, [bufs.keysDump, bufs.keys, bufs.nodes],
    [4 * n, 4 * nPadded, 4 * NODE_WORDS * nodeCount]);
  const error = await popErrorScope(device);
  for (const b of [...Object.values(bufs), params, sortParams]) b.destroy();
  if (error) throw new Error(`WebGPU validation: ${error.message.split('\n')[0]}`);
  return {keys: new Uint32Array(keys), sorted: new Uint32Array(sorted), nodes: new Uint32Array(nodes), nPadded, keyed};
}

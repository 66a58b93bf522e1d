// The packed scene buffer of gpu/kernels/scene.wgsl: a build, trace or frame bundle's instances, TLAS, every mesh's
// BLAS nodes and leaf order, positions and indices in ONE array of u32 words behind a header of offsets, so a kernel
// binds the whole scene as one storage buffer (group 1, binding 0) and keeps the rest of its 8 for itself.
//
//   const scene = uploadScene(device, bundle);          // {buffer, words, instances, meshes, tlasKind, ...}
//   pass.setBindGroup(1, bind(device, pipe, 1, [scene.buffer]));
//
// The word indices below are the constants of scene.wgsl; keep the two files in step.
import {buffer} from './gpu.js';

export const HEADER_WORDS = 16;
export const MESH_WORDS = 8;
export const INSTANCE_WORDS = 32;
export const TLAS_KIND = {sweep: 0, karras: 1};
const H = {version: 0, instances: 1, meshes: 2, tlasKind: 3, tlasNodes: 4, tlasFirstLeaf: 5, tlasKeys: 6,
  instancesAt: 7, tlasNodesAt: 8, tlasKeysAt: 9, meshTableAt: 10, tlasDepth: 11, blasDepth: 12, geometry: 13,
  zero: 15};
const M = {triangles: 0, vertices: 1, blasNodes: 2, blasNodesAt: 3, orderAt: 4, positionsAt: 5, indicesAt: 6};

/** The words of a listed array, or none for a file the bundle does not hold (an empty mesh may lack its BLAS). */
function wordsOf(bundle, name) {
  return bundle.has(name) ? bundle.words(name) : new Uint32Array(0);
}

/** The scene of a bundle (kind build, trace or frame of a mesh scene) packed as scene.wgsl reads it:
 * {words: Uint32Array, instances, meshes, tlasKind, tlasDepth, blasDepth, geometry}. A build bundle carries no
 * positions or indices (geometry false): its trees can be walked, its triangles not intersected. */
export function packScene(bundle) {
  const man = bundle.manifest;
  const meshes = man.counts?.meshes;
  if (!Number.isInteger(meshes)) throw new Error(`${bundle.dir}: the manifest has no mesh count (not a mesh scene?)`);
  const instances = bundle.words('instances.npy');
  const instanceCount = instances.length / INSTANCE_WORDS;
  const tlasKind = man.params?.tlas === 'karras' ? TLAS_KIND.karras : TLAS_KIND.sweep;
  const tlasNodes = wordsOf(bundle, 'tlas_nodes.npy');
  const tlasKeys = wordsOf(bundle, 'tlas_sorted_keys.npy');
  const nodeWords = tlasKind === TLAS_KIND.karras ? 16 : 8;

  const parts = [];
  let at = HEADER_WORDS + meshes * MESH_WORDS;
  const place = (w) => {
    const off = at;
    parts.push([off, w]);
    at += w.length;
    return off;
  };
  const header = new Uint32Array(HEADER_WORDS);
  const table = new Uint32Array(meshes * MESH_WORDS);
  header[H.version] = 1;
  header[H.instances] = instanceCount;
  header[H.meshes] = meshes;
  header[H.tlasKind] = tlasKind;
  header[H.tlasNodes] = tlasNodes.length / nodeWords;
  header[H.tlasFirstLeaf] = tlasKind === TLAS_KIND.sweep ? Math.max(0, (man.tlas?.n_padded ?? 0) - 1) : 0;
  header[H.tlasKeys] = tlasKeys.length;
  header[H.instancesAt] = place(instances);
  header[H.tlasNodesAt] = place(tlasNodes);
  header[H.tlasKeysAt] = place(tlasKeys);
  header[H.meshTableAt] = HEADER_WORDS;
  header[H.tlasDepth] = man.tlas?.depth ?? 0;
  let blasDepth = 0;
  const geometry = meshes > 0 && bundle.has('mesh_0_indices.npy');
  for (let m = 0; m < meshes; m++) {
    const e = m * MESH_WORDS;
    const positions = wordsOf(bundle, `mesh_${m}_positions.npy`);
    const indices = wordsOf(bundle, `mesh_${m}_indices.npy`);
    const nodes = wordsOf(bundle, `blas_${m}_nodes.npy`);
    const order = wordsOf(bundle, `blas_${m}_order.npy`);
    if (geometry && order.length !== indices.length / 3)
      throw new Error(`${bundle.dir}: mesh ${m} has ${indices.length / 3} triangles, its BLAS ${order.length} leaves`);
    table[e + M.triangles] = order.length;
    table[e + M.vertices] = positions.length / 3;
    table[e + M.blasNodes] = nodes.length / 16;
    table[e + M.blasNodesAt] = place(nodes);
    table[e + M.orderAt] = place(order);
    table[e + M.positionsAt] = place(positions);
    table[e + M.indicesAt] = place(indices);
    blasDepth = Math.max(blasDepth, man[`blas_${m}`]?.depth ?? 0);
  }
  header[H.blasDepth] = blasDepth;
  header[H.geometry] = geometry ? 1 : 0;
  header[H.zero] = 0; // trace.wgsl's optimisation barrier reads it: it must stay 0
  const words = new Uint32Array(at);
  words.set(header, 0);
  words.set(table, HEADER_WORDS);
  for (const [off, w] of parts) words.set(w, off);
  return {words, instances: instanceCount, meshes, tlasKind, tlasDepth: header[H.tlasDepth], blasDepth, geometry};
}

/** packScene, uploaded: {buffer, words, ...counts}. Bind it as group 1 of a kernel that includes scene.wgsl. */
export function uploadScene(device, bundle) {
  const s = packScene(bundle);
  return {...s, buffer: buffer(device, s.words.byteLength, {data: s.words, label: 'scene'})};
}

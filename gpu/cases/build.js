// Case family "build": Morton keys and the TLAS sweep tree on the GPU (lib/build.js) for instances:DIST:N scenes,
// every centroid distribution of DESIGN.md §3 x the instance counts of the sort matrix, or for the scenes of
// --scenes. rtoracle build writes the bundle; the GPU uploads its instances and BLAS nodes and dumps its keys, sorted
// keys and node array. Checks, the first failing one returned: 'keys' (here, exactly against tlas_keys.npy),
// check-sort (the sorted buffer) and check-bvh (the nodes, exact mode).
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {buildInputs, buildTlas, MAX_INSTANCES} from '../lib/build.js';
import {readNpy, writeNpy} from '../lib/npy.js';
import {check, checkScenes, rtoracle, scenePath, usage} from '../lib/oracle.js';
import {SORT_SIZES} from '../lib/matrix.js';
import {SENTINEL} from '../lib/sort.js';

export const family = 'build';


/** The centroid distributions: the only ones an instances:DIST:N scene takes (the raw key ones are sort-only). */
export const BUILD_DISTS = ['uniform', 'one-bucket', 'clustered', 'clustered-far', 'line', 'two-clusters'];
/** ci: one build, the small object next to a tight cluster that broke the seeds' radix sort, just past 4096. */
const CI_CASE = {dist: 'clustered', size: 4097};

const instancesCase = (dist, size) => ({family, id: `build/${dist}/${size}`, scene: `instances:${dist}:${size}`,
  dist, size});

export function list(opts) {
  if (opts.scenes) {
    checkScenes(opts.rtoracle, opts.scenes);
    return opts.scenes.map((scene) => {
      const m = scene.match(/^instances:([^:]+):(\d+)$/);
      // A file's case is named by its base name (build/Box.gltf), a procedural scene by itself (build/rtstress:4).
      return m ? instancesCase(m[1], Number(m[2])) : {family, id: `build/${path.basename(scene)}`, scene};
    });
  }
  // Other families' raw distributions are left to them; a list naming none of ours is a mistake.
  const dists = opts.dists ? opts.dists.filter((d) => BUILD_DISTS.includes(d)) : BUILD_DISTS;
  if (opts.dists && !dists.length) usage(`--dists: the build family takes ${BUILD_DISTS.join(', ')}`);
  const sizes = opts.sizes || SORT_SIZES;
  const big = sizes.find((n) => n > MAX_INSTANCES);
  if (big) usage(`--sizes: ${big} instances; a TLAS build holds at most ${MAX_INSTANCES}`);
  if (opts.subset === 'ci' && !opts.dists && !opts.sizes) return [instancesCase(CI_CASE.dist, CI_CASE.size)];
  return dists.flatMap((dist) => sizes.map((n) => instancesCase(dist, n)));
}

/** The same distribution with another instance count (for --shrink); null for a scene that has none. */
export function resize(c, n) {
  return c.dist ? instancesCase(c.dist, n) : null;
}

/** The morton15 of a key as [qx, qy, qz]. */
function cells(key) {
  const q = [0, 0, 0];
  for (let b = 0; b < 15; b++) if ((key >>> (16 + b)) & 1) q[2 - (b % 3)] |= 1 << Math.floor(b / 3);
  return q;
}

const hex = (k) => `0x${k.toString(16).padStart(8, '0')}`;
const describe = (k) => (k === SENTINEL ? 'no key (sentinel)' : `${hex(k)} q = (${cells(k).join(', ')})`);
const f32 = Math.fround; // binary64 then one rounding: exact binary32 for +, -, *, / of binary32 operands
const ulp = (x) => 2 ** (Math.floor(Math.log2(x)) - 23); // of a binary32 x >= 1

/** For a key that differs by one cell on an axis: the oracle's own t = ((c - lo) / (hi - lo)) * 32 (from
 * instance_aabbs.npy, in binary32) on that axis, and how many ulps it lies from the cell boundary between the two
 * cells. A few ulps means a rounding difference (a fused multiply-add in the world box, an approximate division),
 * not a logic fault. */
function boundary(boxes, keyed, i, got, want) {
  const c = (j, a) => f32(f32(boxes[6 * j + a] + boxes[6 * j + 3 + a]) * 0.5);
  const notes = [];
  const qg = cells(got), qw = cells(want);
  for (let a = 0; a < 3; a++) {
    if (Math.abs(qg[a] - qw[a]) !== 1) continue;
    let lo = Infinity, hi = -Infinity;
    for (const j of keyed) lo = Math.min(lo, c(j, a)), hi = Math.max(hi, c(j, a));
    const t = f32(f32(f32(c(i, a) - lo) / f32(hi - lo)) * 32);
    const edge = Math.max(qg[a], qw[a]);
    const away = Math.abs(t - edge) / ulp(edge);
    notes.push(`${'xyz'[a]}: the oracle's t = ${t} is ${away} ulp from the cell edge ${edge}`);
  }
  return notes.length ? ` (${notes.join('; ')})` : '';
}

/** The 'keys' check: the GPU's key of every instance against tlas_keys.npy, which holds one key per keyed
 * instance (a non-empty world box in instance_aabbs.npy, §5) in instance order; the GPU dumps the sentinel for the
 * others. Names the first differing instance. */
function checkKeys(bundle, gpu) {
  const expected = bundle.npy('tlas_keys.npy').data;
  const boxes = new Float32Array(bundle.words('instance_aabbs.npy').buffer); // Aabb: min xyz, max xyz
  const keyed = [...Array(gpu.length).keys()].filter((i) =>
    !(boxes[6 * i] > boxes[6 * i + 3] || boxes[6 * i + 1] > boxes[6 * i + 4] || boxes[6 * i + 2] > boxes[6 * i + 5]));
  if (keyed.length !== expected.length)
    throw new Error(`tlas_keys.npy: ${expected.length} keys for ${keyed.length} keyed instances`);
  const want = new Uint32Array(gpu.length).fill(SENTINEL);
  keyed.forEach((i, e) => (want[i] = expected[e]));
  const i = gpu.findIndex((k, j) => k !== want[j]);
  if (i < 0) return {pass: true, check: 'keys', diagnosis: ''};
  const near = gpu[i] !== SENTINEL && want[i] !== SENTINEL ? boundary(boxes, keyed, i, gpu[i], want[i]) : '';
  return {pass: false, check: 'keys', fault: 'key',
    diagnosis: `instance ${i}: GPU key ${describe(gpu[i])}, expected ${describe(want[i])}${near}`};
}

/** The oracle's build bundle of the scene. */
export function prepare(ctx, c) {
  rtoracle(ctx.rtoracle, ['build', scenePath(c.scene), '-o', path.join(ctx.dir, 'bundle')]);
}

/** The GPU's keys (instance order), sorted keys (n_padded) and sweep tree. */
export async function dump(ctx) {
  const bundle = new Bundle(path.join(ctx.dir, 'bundle'));
  const out = await buildTlas(ctx.device, buildInputs(bundle), {timer: ctx.timer});
  const file = (name) => path.join(ctx.dumpDir, name);
  writeNpy(file('gpu_keys.npy'), out.keys);
  writeNpy(file('gpu_sorted_keys.npy'), out.sorted);
  const nodeType = bundle.files.get('tlas_nodes.npy').dtype; // TlasNode records, as the bundle writes them
  writeNpy(file('gpu_tlas_nodes.npy'), out.nodes, [out.nodes.length / 8], nodeType);
}

export function validate(ctx) {
  const dir = path.join(ctx.dir, 'bundle');
  const bundle = new Bundle(dir);
  const file = (name) => path.join(ctx.dumpDir, name);
  const keys = checkKeys(bundle, readNpy(file('gpu_keys.npy')).data);
  if (!keys.pass) return keys;
  const sort = check(ctx.rtoracle, 'check-sort', ['--input', path.join(dir, 'tlas_keys.npy'),
    '--gpu', file('gpu_sorted_keys.npy'), '--no-artifacts']);
  if (!sort.pass) return {...sort, check: 'check-sort'};
  return {...check(ctx.rtoracle, 'check-bvh', ['--expected', dir, '--gpu', file('gpu_tlas_nodes.npy'),
    '--no-artifacts']), check: 'check-bvh'};
}

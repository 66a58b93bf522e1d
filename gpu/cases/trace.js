// Case family "trace": DESIGN.md §6 ordered traversal on the GPU. rtoracle trace writes a trace bundle (geometry, TLAS,
// BLAS, rays and the expected hits and counters); the GPU traces its rays over the packed scene (lib/scene.js,
// kernels/trace_rays.wgsl) and dumps hits.npy, counters.npy and trace_status.npy; rtoracle check-hits validates the
// hit records, and the counters must equal the bundle's exactly (the GPU runs the oracle's traversal order).
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';
import {uploadScene} from '../lib/scene.js';
import {COUNTER_WORDS, HIT_WORDS, TRACE_STATUS, traceRays, WFRAY_WORDS} from '../lib/trace.js';

export const family = 'trace';

const CORNELL = 'fixtures/CornellBox-nvpro-glTF/cornellBox.gltf';
const REPO = path.join(path.dirname(new URL(import.meta.url).pathname), '..', '..');

// scene, ray set, size (pixels WxH for camera sets, a count otherwise), optional TLAS layout and ray-file edits.
const FULL = [
  ['triangle', 'primary', '64x64'],
  ['rtstress:4', 'primary', '64x64'],
  ['rtstress:4', 'shadow', '64x64'],
  ['rtstress:4', 'random', 4096],
  ['rtstress:4', 'primary', '64x64', 'karras'],
  ['sphere:3', 'grazing', 4096],
  ['sphere:3', 'axis', 4096],
  ['instances:clustered:257', 'random', 4096],
  ['instances:clustered:257', 'random', 4096, 'karras'],
  [CORNELL, 'primary', '48x36'],
  [CORNELL, 'random', 2048],
  ['random:3', 'random', 4096],
  ['random:3', 'grazing', 4096],
  ['random:3', 'random', 4096, 'sweep', 'flags'],
  ['random:7', 'random', 4096, 'karras', 'flags'],
];
const CI = [['rtstress:4', 'primary', '64x64']];

const sceneName = (s) => (s.includes('/') ? path.basename(s) : s);

function makeCase(scene, rays, size, tlas = 'sweep', edit = null) {
  const id = ['trace', sceneName(scene), rays + (edit ? `+${edit}` : ''), String(size)]
    .concat(tlas === 'karras' ? ['karras'] : []).join('/');
  return {family, id, scene, rays, size, tlas, edit};
}

/** The family's cases; --scenes replaces the scenes (each traced with primary 64x64 and random 4096 rays). */
export function list(opts) {
  if (opts.scenes) return opts.scenes.flatMap((s) => [makeCase(s, 'primary', '64x64'), makeCase(s, 'random', 4096)]);
  return (opts.subset === 'ci' ? CI : FULL).map((c) => makeCase(...c));
}

/** rtoracle's arguments for a ray set of a case. */
function rayArgs(c) {
  if (typeof c.size === 'string') {
    const [w, h] = c.size.split('x');
    return ['--rays', c.rays, '--width', w, '--height', h];
  }
  return ['--rays', c.rays, '--count', String(c.size)];
}

function scenePath(scene) {
  return scene.includes('/') && !path.isAbsolute(scene) ? path.join(REPO, scene) : scene;
}

// The 'flags' edit: the same rays with every §6 flag and cull mask in turn (ray i takes FLAGS[i % 7] and
// MASKS[(i / 7) % 5]; 7 and 5 are coprime, so every pair occurs), traced by the oracle from the edited ray file.
const FLAGS = [0x1, 0x11, 0x21, 0xd, 0x15, 0x0, 0x25];
const MASKS = [0xff, 0x01, 0x80, 0x00, 0x5a];
function editFlags(words) {
  const out = words.slice();
  for (let i = 0; i < out.length / WFRAY_WORDS; i++) {
    out[i * WFRAY_WORDS + 9] = FLAGS[i % FLAGS.length];
    out[i * WFRAY_WORDS + 10] = MASKS[Math.floor(i / FLAGS.length) % MASKS.length];
  }
  return out;
}

/** The bundle of a case (a generated ray set, or its flag-edited ray file traced again). */
function makeBundle(ctx, c) {
  const out = path.join(ctx.dir, 'bundle');
  const base = [scenePath(c.scene), '--tlas', c.tlas, '--threads', '1'];
  if (!c.edit) {
    rtoracle(ctx.rtoracle, ['trace', ...base, ...rayArgs(c), '-o', out]);
    return new Bundle(out);
  }
  const gen = path.join(ctx.dir, 'generated');
  rtoracle(ctx.rtoracle, ['trace', ...base, ...rayArgs(c), '-o', gen]);
  const g = new Bundle(gen);
  const raysFile = path.join(ctx.dir, 'rays_flags.npy');
  writeNpy(raysFile, editFlags(g.words('rays.npy')), [g.manifest.trace.count], g.files.get('rays.npy').dtype);
  rtoracle(ctx.rtoracle, ['trace', ...base, '--rays', raysFile, '-o', out]);
  return new Bundle(out);
}

/** The first ray whose counters differ from the bundle's, named with its field; null when all agree. */
function compareCounters(expected, actual) {
  const names = ['nodesVisited', 'boxTests', 'triangleTests', 'instanceEntries'];
  for (let i = 0; i < expected.length; i++) {
    if (expected[i] !== actual[i]) {
      const ray = Math.floor(i / COUNTER_WORDS), f = i % COUNTER_WORDS;
      return `ray ${ray}: ${names[f]} ${actual[i]}, expected ${expected[i]}`;
    }
  }
  return null;
}

/** The first ray the kernel flagged (refused, or its stack overflowed); null when none. */
function statusFault(status) {
  const i = status.findIndex((s) => s !== 0);
  if (i < 0) return null;
  const what = Object.entries(TRACE_STATUS).filter(([, bit]) => status[i] & bit).map(([k]) => k).join('+');
  return `ray ${i}: trace status ${what} (${status.filter((s) => s !== 0).length} rays flagged)`;
}

export async function run(ctx, c) {
  const bundle = makeBundle(ctx, c);
  const scene = uploadScene(ctx.device, bundle);
  const rays = bundle.words('rays.npy');
  const n = rays.length / WFRAY_WORDS;
  let out;
  try {
    out = await traceRays(ctx.device, scene, rays, {timer: ctx.timer});
  } finally {
    scene.buffer.destroy();
  }
  const hitsPath = path.join(ctx.dir, 'hits.npy');
  writeNpy(hitsPath, out.hits, [n], bundle.files.get('hits.npy').dtype);
  writeNpy(path.join(ctx.dir, 'counters.npy'), out.counters, [n], bundle.files.get('counters.npy').dtype);
  writeNpy(path.join(ctx.dir, 'trace_status.npy'), out.status, [n]);
  if (out.hits.length !== n * HIT_WORDS) throw new Error(`read back ${out.hits.length} hit words for ${n} rays`);

  const status = statusFault(out.status);
  if (status) return {pass: false, check: 'trace-status', diagnosis: status};
  const hits = {...check(ctx.rtoracle, 'check-hits', ['--expected', bundle.dir, '--gpu', hitsPath, '--no-artifacts']),
    check: 'check-hits'};
  if (!hits.pass) return hits;
  const counters = compareCounters(bundle.words('counters.npy'), out.counters);
  if (counters) return {pass: false, check: 'counters', diagnosis: counters};
  return {...hits, check: 'check-hits+counters'};
}

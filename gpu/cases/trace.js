// Case family "trace": DESIGN.md §6 ordered traversal on the GPU. rtoracle trace writes a trace bundle (geometry,
// TLAS, BLAS, rays and the expected hits and counters); the GPU traces its rays over the packed scene (lib/scene.js,
// kernels/trace_rays.wgsl) and dumps hits.npy, counters.npy and trace_status.npy; rtoracle check-hits validates the
// hit records, and the counters must equal the bundle's exactly (the GPU runs the oracle's traversal order).
import fs from 'node:fs';
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {npyWords, readNpy, writeNpy} from '../lib/npy.js';
import {check, checkScenes, REPO, rtoracle, scenePath} from '../lib/oracle.js';
import {uploadScene} from '../lib/scene.js';
import {COUNTER_WORDS, HIT_WORDS, TRACE_STATUS, traceRays, WFRAY_WORDS} from '../lib/trace.js';

export const family = 'trace';

const CORNELL = 'fixtures/CornellBox-nvpro-glTF/cornellBox.gltf';
// scene, ray set, size (pixels WxH for camera sets, a count otherwise), optional TLAS layout and ray-file edits.
const FULL = [
  ['triangle', 'primary', '64x64'],
  ['triangle', 'primary', '64x64', 'karras'],
  ['triangle', 'primary', '8x8', 'sweep', 'refused'],
  ['rtstress:4', 'primary', '128x96'],
  ['rtstress:4', 'shadow', '128x96'],
  ['rtstress:4', 'random', 16384],
  ['rtstress:4', 'primary', '128x96', 'karras'],
  ['rtstress:8', 'shadow', '128x96'],
  ['sphere:3', 'grazing', 16384],
  ['sphere:3', 'axis', 16384],
  ['instances:clustered:257', 'random', 16384],
  ['instances:clustered:257', 'random', 16384, 'karras'],
  [CORNELL, 'primary', '96x72'],
  [CORNELL, 'random', 16384],
  [CORNELL, 'grazing', 16384, 'sweep', 'flags'],
  ['random:3', 'random', 16384],
  ['random:3', 'grazing', 16384],
  ['random:3', 'random', 16384, 'sweep', 'flags'],
  ['random:7', 'axis', 16384, 'karras', 'flags'],
];
const CI = [['rtstress:4', 'primary', '64x64']];
// The committed trace goldens (fixtures/golden), traced as they are: what a harness copied from here first meets.
const GOLDEN = ['trace-Box', 'trace-rtstress-2', 'trace-rtstress-2-random'];

const sceneName = (s) => (s.includes('/') ? path.basename(s) : s);

function makeCase(scene, rays, size, tlas = 'sweep', edit = null) {
  const id = ['trace', sceneName(scene), rays + (edit ? `+${edit}` : ''), String(size)]
    .concat(tlas === 'karras' ? ['karras'] : []).join('/');
  return {family, id, scene, rays, size, tlas, edit};
}

/** The family's cases; --scenes replaces the scenes (each traced with primary 64x64 and random 4096 rays). */
export function list(opts) {
  if (!opts.scenes && opts.subset === 'ci') return CI.map((c) => makeCase(...c));
  if (!opts.scenes) return FULL.map((c) => makeCase(...c)).concat(GOLDEN.map((g) => ({family, id: `trace/golden/${g}`,
    golden: g})));
  checkScenes(opts.rtoracle, opts.scenes);
  return opts.scenes.flatMap((s) => [makeCase(s, 'primary', '64x64'), makeCase(s, 'random', 4096)]);
}

/** rtoracle's arguments for a ray set of a case. */
function rayArgs(c) {
  if (typeof c.size === 'string') {
    const [w, h] = c.size.split('x');
    return ['--rays', c.rays, '--width', w, '--height', h];
  }
  return ['--rays', c.rays, '--count', String(c.size)];
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

// The 'refused' edit: rays the contract refuses (§6: a non-finite origin, direction, tMin or tMax, or tMin > tMax),
// as [ray, word, value] (WfRay words: origin 0..2, tMin 3, dir 4..6, tMax 7); ray 17 gets tMin 2 > tMax 1.
const REFUSED = [[5, 0, NaN], [9, 5, Infinity], [17, 3, 2], [17, 7, 1], [23, 7, -Infinity], [30, 3, NaN]];
function editRefused(words) {
  const out = words.slice();
  const f = new Float32Array(out.buffer);
  for (const [ray, word, value] of REFUSED) f[ray * WFRAY_WORDS + word] = value;
  return out;
}

/** The bundle of a case, in the case's directory (a committed golden is copied there by prepare(), so a prepared
 * directory holds everything it needs and can move to another path or host). */
function bundleOf(ctx) {
  return new Bundle(path.join(ctx.dir, 'bundle'));
}

/** The oracle's side: a generated ray set's bundle, or its flag-edited ray file traced again; for the 'refused' case
 * also the edited rays and the oracle's refusal of them (oracle_refusal.txt). */
export function prepare(ctx, c) {
  const out = path.join(ctx.dir, 'bundle');
  if (c.golden) {
    fs.cpSync(path.join(REPO, 'fixtures', 'golden', c.golden), out, {recursive: true});
    return;
  }
  const base = [scenePath(c.scene), '--tlas', c.tlas, '--threads', '1'];
  if (c.edit === 'flags') {
    const gen = path.join(ctx.dir, 'generated');
    rtoracle(ctx.rtoracle, ['trace', ...base, ...rayArgs(c), '-o', gen]);
    const g = new Bundle(gen);
    const raysFile = path.join(ctx.dir, 'rays_flags.npy');
    writeNpy(raysFile, editFlags(g.words('rays.npy')), [g.manifest.trace.count], g.files.get('rays.npy').dtype);
    rtoracle(ctx.rtoracle, ['trace', ...base, '--rays', raysFile, '-o', out]);
  } else {
    rtoracle(ctx.rtoracle, ['trace', ...base, ...rayArgs(c), '-o', out]);
  }
  if (c.edit !== 'refused') return;
  const b = new Bundle(out);
  const file = path.join(ctx.dir, 'rays_refused.npy');
  writeNpy(file, editRefused(b.words('rays.npy')), [b.manifest.trace.count], b.files.get('rays.npy').dtype);
  let oracleSays = '';
  try {
    rtoracle(ctx.rtoracle, ['trace', scenePath(c.scene), '--rays', file, '-o', path.join(ctx.dir, 'refused')]);
  } catch (e) {
    oracleSays = e.message;
  }
  fs.writeFileSync(path.join(ctx.dir, 'oracle_refusal.txt'), oracleSays + '\n');
}

/** The GPU's side: the case's rays traced over the packed scene; hits.npy, counters.npy, trace_status.npy. */
export async function dump(ctx, c) {
  const bundle = bundleOf(ctx, c);
  const rays = c.edit === 'refused' ? npyWords(path.join(ctx.dir, 'rays_refused.npy')) : bundle.words('rays.npy');
  const n = rays.length / WFRAY_WORDS;
  const scene = uploadScene(ctx.device, bundle);
  try {
    const out = await traceRays(ctx.device, scene, rays, {timer: ctx.timer});
    if (out.hits.length !== n * HIT_WORDS) throw new Error(`read back ${out.hits.length} hit words for ${n} rays`);
    writeNpy(path.join(ctx.dumpDir, 'hits.npy'), out.hits, [n], bundle.files.get('hits.npy').dtype);
    writeNpy(path.join(ctx.dumpDir, 'counters.npy'), out.counters, [n], bundle.files.get('counters.npy').dtype);
    writeNpy(path.join(ctx.dumpDir, 'trace_status.npy'), out.status, [n]);
  } finally {
    scene.buffer.destroy();
  }
}

export function validate(ctx, c) {
  const bundle = bundleOf(ctx, c);
  const out = {hits: npyWords(path.join(ctx.dumpDir, 'hits.npy')),
    counters: npyWords(path.join(ctx.dumpDir, 'counters.npy')), status: readNpy(path.join(ctx.dumpDir,
      'trace_status.npy')).data};
  return c.edit === 'refused' ? validateRefused(ctx, bundle, out) : validateTrace(ctx, bundle, out);
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

/** The 'refused' case: the bundle's rays with REFUSED's edits. The oracle refuses the whole batch, naming the first
 * bad ray; the GPU must flag exactly the edited rays REFUSED with the miss record of their tMax and zero counters,
 * and trace every other ray as the bundle did (within §9: a real GPU may fuse multiply-adds). */
function validateRefused(ctx, bundle, out) {
  const oracleSays = fs.readFileSync(path.join(ctx.dir, 'oracle_refusal.txt'), 'utf8').trim();
  const first = Math.min(...REFUSED.map(([r]) => r));
  if (!oracleSays.includes(`ray ${first} `))
    return {pass: false, check: 'refused', diagnosis: `the oracle did not refuse ray ${first}: ${oracleSays}`};
  const rays = npyWords(path.join(ctx.dir, 'rays_refused.npy'));
  const n = rays.length / WFRAY_WORDS;
  const expHits = bundle.words('hits.npy'), expCnt = bundle.words('counters.npy');
  const bad = new Set(REFUSED.map(([r]) => r));
  for (let i = 0; i < n; i++) {
    const hit = out.hits.subarray(i * HIT_WORDS, (i + 1) * HIT_WORDS);
    const cnt = out.counters.subarray(i * COUNTER_WORDS, (i + 1) * COUNTER_WORDS);
    let want, wantCnt, wantStatus;
    if (bad.has(i)) {
      want = missRecord(rays[i * WFRAY_WORDS + 7]);
      wantCnt = new Uint32Array(COUNTER_WORDS);
      wantStatus = TRACE_STATUS.refused;
    } else {
      want = expHits.subarray(i * HIT_WORDS, (i + 1) * HIT_WORDS);
      wantCnt = expCnt.subarray(i * COUNTER_WORDS, (i + 1) * COUNTER_WORDS);
      wantStatus = 0;
    }
    const w = want.findIndex((x, k) => !sameWord(k, x, hit[k]));
    if (out.status[i] !== wantStatus || w >= 0 || wantCnt.some((x, k) => x !== cnt[k]))
      return {pass: false, check: 'refused', diagnosis: `ray ${i}: status ${out.status[i]} (expected ${wantStatus})` +
        (w >= 0 ? `, hit word ${w} 0x${hit[w].toString(16)} (expected 0x${want[w].toString(16)})` : '') +
        `, counters ${Array.from(cnt)} (expected ${Array.from(wantCnt)})`};
  }
  return {pass: true, check: 'refused', diagnosis: ''};
}

const asFloat = (w) => new Float32Array(new Uint32Array([w]).buffer)[0];

/** Word k of a hit record compared under §9: t (word 0) within 1e-5·max(1, |t|), the barycentrics (words 4, 5) within
 * 1e-4, every other word exactly (a real GPU may fuse multiply-adds; llvmpipe matches bit for bit anyway). */
function sameWord(k, want, got) {
  if (want === got) return true;
  const a = asFloat(want), b = asFloat(got);
  if (k === 0) return Math.abs(a - b) <= 1e-5 * Math.max(1, Math.abs(a));
  return (k === 4 || k === 5) && Math.abs(a - b) <= 1e-4;
}

/** §6's miss record of a ray whose tMax has the bits tMaxWord, as words. */
function missRecord(tMaxWord) {
  const h = new Uint32Array(HIT_WORDS);
  h.set([tMaxWord, 0xFFFFFFFF, 0xFFFFFFFF, 0xFFFFFFFF, 0, 0, 0xFFFFFFFF, 1]);
  return h;
}

/** The first ray the kernel flagged (refused, or its stack overflowed); null when none. */
function statusFault(status) {
  const i = status.findIndex((s) => s !== 0);
  if (i < 0) return null;
  const what = Object.entries(TRACE_STATUS).filter(([, bit]) => status[i] & bit).map(([k]) => k).join('+');
  return `ray ${i}: trace status ${what} (${status.filter((s) => s !== 0).length} rays flagged)`;
}

function validateTrace(ctx, bundle, out) {
  const hitsPath = path.join(ctx.dumpDir, 'hits.npy');
  const status = statusFault(out.status);
  if (status) return {pass: false, check: 'trace-status', diagnosis: status};
  const hits = {...check(ctx.rtoracle, 'check-hits', ['--expected', bundle.dir, '--gpu', hitsPath, '--no-artifacts']),
    check: 'check-hits'};
  if (!hits.pass) return hits;
  const counters = compareCounters(bundle.words('counters.npy'), out.counters);
  if (!counters) return {...hits, check: 'check-hits+counters'};
  // llvmpipe evaluates the kernel as written, so its counters are the oracle's. A real GPU may fuse multiply-adds
  // in the slab tests, which moves box boundaries by an ulp and with them the path of a ray that grazes a box:
  // its counters are reported there, not failed (check-hits still holds its records to §9).
  if (ctx.backend !== 'opengl') return {...hits, check: 'check-hits', diagnosis: `counters not exact: ${counters}`};
  return {pass: false, check: 'counters', diagnosis: counters};
}

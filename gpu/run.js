// The GPU runner: every case of the chosen families runs its kernels on a WebGPU device, dumps the buffers to .npy and
// validates them with rtoracle's check-* commands. Prints a table (case -> pass/fail with the oracle's diagnosis),
// writes it as JSON and a static HTML page, and exits 1 on any failure (2 on bad usage).
// Usage: gpu/run --help
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import {openDevice} from './lib/device.js';
import {setKernelDir} from './lib/gpu.js';
import {takeShaderError} from './lib/device.js';
import {patterns} from './lib/patterns.js';
import {sizeRanges, sweepSizes} from './lib/matrix.js';
import {DEFAULT_RTORACLE, usage} from './lib/oracle.js';
import {writeHtml} from './lib/report.js';
import {Timer} from './lib/timing.js';

const FAMILIES = ['bitonic', 'bitonic-wg', 'radix', 'build', 'trace', 'frame', 'vbuffer', 'fluid'];
const DEFAULT_FAMILIES = FAMILIES;

const HELP = `usage: gpu/run [--families LIST] [--subset ci|full] [--dists LIST] [--sizes LIST] [--scenes LIST]
               [--repeat K] [--timestamps] [--shrink] [--racy-scatter] [--drop-barrier PASS]
               [--sweep SPECS] [--kernels DIR] [--rtoracle PATH] [--out DIR] [--json FILE] [--html FILE]
               [--prepare-only | --dump-only | --check-only]

Runs the WGSL kernels under gpu/kernels on a WebGPU device (Dawn: Vulkan when a GPU is there, else Mesa llvmpipe
through OpenGL in compatibility mode; RTO_GPU_BACKEND=vulkan|opengl forces one), dumps every buffer as .npy and
validates each dump with rtoracle check-sort / check-bvh / check-hits / check-frame / check-vbuffer.

Families (default: all):
  bitonic      the canonical network, one dispatch per (k, j) pass; every pass dumped and checked
  bitonic-wg   one workgroup, barriers between passes, up to 16384 keys; every pass dumped and checked
  radix        LSD radix, 4-bit digits, per-tile histograms, prefix and stable scatter; every pass checked
  build        Morton keys, sort and the TLAS sweep tree of instances:DIST:N scenes (check-sort, check-bvh)
  trace        ordered traversal over TLAS and BLAS, 96-byte hit records (check-hits)
  frame        the wavefront chain with dispatchWorkgroupsIndirect: triangle and sun-shadow (check-frame)
  vbuffer      the visibility buffer (seed 004): 1x/4x MSAA G-buffer, edge mask, material pass (check-vbuffer)
  fluid        seed 003's density volume: splat (atomicAdd), resolve to rgba16float, occupancy grid and its mips
               (check-volume); the raymarch of the volume, with and without empty-space skipping (check-raymarch)

options:
  --families LIST     comma-separated families to run
  --subset S          ci: sorts of 1, 2, 255-257, 4096, 4097 keys, one build, one traced frame per program
                      (vbuffer: triangle and rtstress:2 at 64x48; fluid: four splats of 16^3-24^3 voxels,
                      one raymarched at 48x36 with and without skipping)
                      (default full)
  --dists LIST        sort / build distributions (default: every distribution of DESIGN.md §3)
  --sizes LIST        sort sizes, or instance counts of builds (default 1,2,3,255,256,257,4095,4096,4097,16384,65535)
  --scenes LIST       trace / frame scenes, fluid generators (default: the family's own list)
  --repeat K          run every case K times and report pass x/K (a race fails intermittently)
  --timestamps        per-kernel GPU time through timestamp-query (where the device has it)
  --shrink            on a failing sort or build case, bisect the size and report the smallest failing case
  --racy-scatter      radix: an unsynchronised scatter (the fault the oracle must diagnose)
  --drop-barrier P    bitonic-wg: leave out the barrier after pass P (0-based), a planted race
  --sweep SPECS       bitonic and radix over generated sizes instead of the matrix (keys made on the fly, the
                      final sort checked with check-sort --input; distributions from --dists, default random):
                      tile:P every n in [P, 2P + 1], pow2:K 2^k - 1, 2^k, 2^k + 1 for k <= K (<= 25), n:A-B;
                      comma-separated; the summary gives per-size pass counts
  --kernels DIR       .wgsl files there replace the bundled kernels of the same name (every one must name
                      a bundled kernel; reports list the ones replaced)
  --rtoracle PATH     the rtoracle binary (default build/oracle/rtoracle)
  --out DIR           keep every case's inputs and dumps in DIR/<case> (default: a temporary directory, removed)
  --json FILE         write the results as JSON
  --html FILE         write the results as a static HTML page (images are copied next to it)
  --prepare-only      only write every case's oracle inputs and expected bundles into --out DIR
  --dump-only         only run the kernels and write their dumps into --out DIR (inputs made if missing); repeats
                      whose dumps equal the first run's are recorded, not kept
  --check-only        only validate the dumps an earlier --dump-only left in --out DIR (on a machine with rtoracle)
  -h, --help          print this help and exit

Exit status: 0 every case passes, 1 a case fails, 2 bad usage or setup.`;

function parseArgs(argv) {
  const o = {families: DEFAULT_FAMILIES, subset: 'full', dists: null, sizes: null, scenes: null, repeat: 1,
    timestamps: false, shrink: false, racyScatter: false, dropBarrier: null, kernels: null,
    rtoracle: DEFAULT_RTORACLE, out: null, json: null, html: null, passDumpLimit: 65536};
  const flags = {'--timestamps': 'timestamps', '--shrink': 'shrink', '--racy-scatter': 'racyScatter',
    '--prepare-only': 'prepareOnly', '--dump-only': 'dumpOnly', '--check-only': 'checkOnly'};
  const list = (v) => v.split(',').filter((s) => s.length);
  const count = (name, v, lo, hi) => {
    if (!/^\d+$/.test(v) || Number(v) < lo || Number(v) > hi) usage(`${name}: '${v}' is not an integer ${lo} .. ${hi}`);
    return Number(v);
  };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a === '-h' || a === '--help') {
      console.log(HELP);
      process.exit(0);
    }
    if (flags[a]) {
      o[flags[a]] = true;
      continue;
    }
    if (i + 1 >= argv.length) usage(`unknown option or missing value: ${a}`);
    const v = argv[++i];
    switch (a) {
      case '--families':
        o.families = list(v);
        for (const f of o.families) if (!FAMILIES.includes(f)) usage(`--families: unknown family '${f}'`);
        break;
      case '--subset':
        if (v !== 'ci' && v !== 'full') usage(`--subset: '${v}' is neither ci nor full`);
        o.subset = v;
        break;
      case '--dists': o.dists = list(v); break;
      case '--sizes': o.sizes = list(v).map((s) => count('--sizes', s, 1, 1 << 24)); break;
      case '--scenes': o.scenes = list(v); break;
      case '--sweep':
        try {
          o.sweep = sweepSizes(v);
        } catch (e) {
          usage(e.message);
        }
        break;
      case '--repeat': o.repeat = count('--repeat', v, 1, 1000); break;
      case '--drop-barrier': o.dropBarrier = count('--drop-barrier', v, 0, 1000); break;
      case '--kernels': o.kernels = v; break;
      case '--rtoracle': o.rtoracle = v; break;
      case '--out': o.out = v; break;
      case '--json': o.json = v; break;
      case '--html': o.html = v; break;
      default: usage(`unknown option: ${a}`);
    }
  }
  const modes = [o.prepareOnly, o.dumpOnly, o.checkOnly].filter(Boolean).length;
  if (modes > 1) usage('--prepare-only, --dump-only and --check-only exclude each other');
  if (modes && !o.out) usage('--prepare-only, --dump-only and --check-only need --out DIR');
  if (o.checkOnly && !fs.existsSync(o.out)) usage(`--check-only: no directory ${o.out}`);
  if (!o.dumpOnly && !fs.existsSync(o.rtoracle))
    usage(`no rtoracle binary at ${o.rtoracle} (build it, or pass --rtoracle PATH)`);
  if (o.sweep && o.families.some((f) => f !== 'bitonic' && f !== 'radix'))
    usage('--sweep applies to the bitonic and radix families (pass --families bitonic,radix)');
  if (o.sweep && o.sizes) usage('--sweep and --sizes exclude each other');
  if (o.kernels && !fs.statSync(o.kernels, {throwIfNoEntry: false})?.isDirectory())
    usage(`--kernels: ${o.kernels} is not a directory`);
  if (o.kernels) {
    try {
      o.userKernels = setKernelDir(path.resolve(o.kernels));
    } catch (e) {
      usage(e.message);
    }
  }
  return o;
}

const harnessFault = (diagnosis) => ({pass: false, check: 'harness', diagnosis});

/** A kernel that does not compile or link is a setup error, not a data fault: its first WGSL error in one line
 * (file:line:column), exit status 2, and no verdict for any case. */
function setupCheck(ctx) {
  const e = takeShaderError(ctx.device);
  if (!e) return;
  console.error(`gpu/run: ${e} (a kernel does not compile: no verdict)`);
  process.exit(2);
}

/** fn's result, or a failure whose diagnosis is the error's first line (a harness fault, not the oracle's). */
async function attempt(fn) {
  try {
    return await fn();
  } catch (e) {
    return harnessFault(String(e.message || e).split('\n')[0]);
  }
}

function filesOf(dir) {
  return fs.readdirSync(dir, {recursive: true}).filter((f) => fs.statSync(path.join(dir, f)).isFile()).sort();
}

function sameDumps(a, b) {
  const fa = filesOf(a), fb = filesOf(b);
  return fa.length === fb.length && fa.every((f, i) => f === fb[i] &&
    fs.readFileSync(path.join(a, f)).equals(fs.readFileSync(path.join(b, f))));
}

/** Runs a case `repeat` times in dir through the phases the mode asks for: prepare (the oracle's inputs, kept while
 * the case's parameters are unchanged), dump (the kernels; a repeat whose dumps equal the first run's is recorded in
 * repeats.json and removed) and validate (the oracle's checks, once per distinct dump). Returns {passes, first,
 * last, gpu_ms, prepared}. A family with only run(ctx, c) supports the full mode alone. */
async function runCase(ctx, mod, c, dir, repeat) {
  const {opts, timer} = ctx;
  const split = Boolean(mod.dump);
  if (!split && (opts.prepareOnly || opts.dumpOnly || opts.checkOnly))
    return {passes: 0, first: harnessFault(`family ${mod.family} runs only in the full mode`)};
  const stamp = path.join(dir, 'case.json');
  const params = JSON.stringify(c);
  if (opts.checkOnly) {
    if (!fs.existsSync(stamp) || fs.readFileSync(stamp, 'utf8') !== params)
      return {passes: 0, first: harnessFault(`${dir} holds no dump of this case`)};
  } else if (!split || !fs.existsSync(stamp) || fs.readFileSync(stamp, 'utf8') !== params) {
    fs.rmSync(dir, {recursive: true, force: true});
    fs.mkdirSync(dir, {recursive: true});
    if (split) {
      const r = await attempt(() => mod.prepare({...ctx, dir}, c));
      if (r && r.pass === false) return {passes: 0, first: r};
    }
    fs.writeFileSync(stamp, params);
  }
  if (opts.prepareOnly) return {prepared: true};
  if (!split) {
    const r = await attempt(() => mod.run({...ctx, dir, dumpDir: dir}, c));
    await timer.collect();
    setupCheck(ctx);
    return {passes: r.pass ? 1 : 0, first: r.pass ? null : r, last: r, gpu_ms: timer.take()};
  }
  const record = path.join(dir, 'repeats.json');
  let same = [], gpuMs = {};
  if (opts.checkOnly) {
    // Dumps another harness wrote into DIR/<case>/gpu/ after --prepare-only come without a record: one run.
    if (fs.existsSync(record)) ({same = [], gpu_ms: gpuMs = {}} = JSON.parse(fs.readFileSync(record, 'utf8')));
    else same = [0];
  } else {
    for (let r = 0; r < repeat; r++) {
      const dumpDir = path.join(dir, r ? `gpu-${r}` : 'gpu');
      fs.rmSync(dumpDir, {recursive: true, force: true});
      fs.mkdirSync(dumpDir, {recursive: true});
      const err = await attempt(async () => {
        await mod.dump({...ctx, dir, dumpDir}, c);
        await timer.collect();
      });
      setupCheck(ctx);
      if (err && err.pass === false) {
        fs.writeFileSync(path.join(dumpDir, 'harness-error.txt'), err.diagnosis + '\n');
        same.push(r);
        continue;
      }
      const twin = same.findIndex((s, i) => s === i && sameDumps(dumpDir, path.join(dir, i ? `gpu-${i}` : 'gpu')));
      if (r && twin >= 0) {
        fs.rmSync(dumpDir, {recursive: true, force: true});
        same.push(twin);
      } else same.push(r);
    }
    gpuMs = timer.take();
    fs.writeFileSync(record, JSON.stringify({repeat, same, gpu_ms: gpuMs}, null, 1) + '\n');
    if (opts.dumpOnly) return {dumped: true, gpu_ms: gpuMs, distinct: new Set(same).size};
  }
  const verdicts = new Map();
  let passes = 0, first = null, last = null;
  for (const s of same) {
    if (!verdicts.has(s)) {
      const dumpDir = path.join(dir, s ? `gpu-${s}` : 'gpu');
      const err = path.join(dumpDir, 'harness-error.txt');
      verdicts.set(s, fs.existsSync(err)
        ? harnessFault(fs.readFileSync(err, 'utf8').trim())
        : await attempt(() => mod.validate({...ctx, dir, dumpDir}, c)));
    }
    last = verdicts.get(s);
    if (last.pass) passes++;
    else if (!first) first = last;
  }
  return {passes, runs: same.length, first, last, gpu_ms: gpuMs, distinct: verdicts.size};
}

/** --shrink: bisect the size between 0 (assumed passing) and a failing size; the smallest failing case found. */
async function shrink(ctx, mod, c, caseDir) {
  let lo = 0, hi = c.size, smallest = null;
  while (hi - lo > 1) {
    const mid = Math.floor((lo + hi) / 2);
    const m = mod.resize(c, mid);
    if (!m) break;
    const r = await runCase(ctx, mod, m, caseDir(m), 1);
    if (r.passes === 1) lo = mid;
    else {
      hi = mid;
      smallest = {id: m.id, size: mid, diagnosis: (r.first || {}).diagnosis};
    }
  }
  return smallest || {id: c.id, size: c.size, note: 'no smaller size fails'};
}

async function main() {
  const opts = parseArgs(process.argv.slice(2));
  const root = opts.out ? path.resolve(opts.out) : fs.mkdtempSync(path.join(os.tmpdir(), 'rto-gpu-'));
  fs.mkdirSync(root, {recursive: true});
  // --check-only and --prepare-only need no GPU; --check-only reports the device that made the dumps.
  let dev = {device: null, backend: opts.checkOnly ? 'an external harness' : 'none', gpu: null, adapter: null};
  const deviceFile = path.join(root, 'device.json');
  if (!opts.checkOnly && !opts.prepareOnly) {
    try {
      dev = await openDevice();
    } catch (e) {
      console.error(`gpu/run: ${e.message}`);
      process.exit(2);
    }
  }
  globalThis.rtoGpu = dev.gpu; // the Dawn instance must outlive every object made from it
  const info = (dev.adapter && dev.adapter.info) || {};
  let adapter = [info.vendor, info.architecture, info.device, info.description].filter(Boolean).join(' ');
  let backend = dev.backend;
  if (opts.dumpOnly) fs.writeFileSync(deviceFile, JSON.stringify({backend, adapter}) + '\n');
  if (opts.checkOnly && fs.existsSync(deviceFile))
    ({backend, adapter} = JSON.parse(fs.readFileSync(deviceFile, 'utf8')));
  const timer = new Timer(dev.device, opts.timestamps);
  const ctx = {device: dev.device, backend, rtoracle: opts.rtoracle, opts, timer};
  console.log(`device: ${backend}${adapter ? ` (${adapter})` : ''}${opts.timestamps && dev.device
    ? timer.on ? ', timestamps on' : ', no timestamp-query: no GPU times' : ''}`);
  const userKernels = opts.userKernels ? opts.userKernels.map((f) => path.join(path.resolve(opts.kernels), f)) : [];
  if (userKernels.length) console.log(`your kernels: ${userKernels.join(', ')} (the rest bundled)`);
  // llvmpipe runs a workgroup's invocations one group of lanes after another and executes a barrier even inside a
  // branch, so a barrier moved, dropped or made conditional passes there: a user's kernel with barriers gets a caveat.
  const warnings = [];
  const barriered = userKernels.filter((f) => /\b(workgroupBarrier|storageBarrier)\s*\(/.test(fs.readFileSync(f, 'utf8')));
  if (barriered.length && /llvmpipe/i.test(adapter))
    warnings.push(`llvmpipe cannot show barrier races: ${barriered.map((f) => path.basename(f)).join(', ')} ` +
      `${barriered.length > 1 ? 'use' : 'uses'} barriers, and a pass here is not a pass on a GPU; run on a GPU`);
  for (const w of warnings) console.log(`warning: ${w}`);

  const results = [];
  const started = Date.now();
  for (const family of opts.families) {
    const mod = await import(`./cases/${family}.js`);
    for (const c of mod.list(opts)) {
      const caseDir = (x) => path.join(root, x.id.replace(/[^A-Za-z0-9._-]+/g, '_'));
      const t0 = Date.now();
      const r = await runCase(ctx, mod, c, caseDir(c), opts.repeat);
      if (r.prepared || r.dumped) {
        console.log(`${c.id.padEnd(44)} ${r.prepared ? 'prepared' : `dumped ${opts.repeat} run(s), ${r.distinct} ` +
          'distinct'}`);
        continue;
      }
      const shown = r.first || r.last || {};
      const runs = r.runs || opts.repeat; // --check-only: as many as were dumped
      const row = {case: c.id, family, params: c, pass: r.passes === runs, passes: r.passes, repeat: runs,
        distinct_dumps: r.distinct || null, check: shown.check || null, fault: shown.fault || null,
        diagnosis: shown.diagnosis || '', gpu_ms: r.gpu_ms || {}, wall_s: (Date.now() - t0) / 1000, dir: opts.out ? caseDir(c) : null /* a temporary root is removed */,
        images: shown.images || null};
      if (!row.pass && opts.shrink && mod.resize && c.size > 1) row.shrunk = await shrink(ctx, mod, c, caseDir);
      results.push(row);
      const times = Object.entries(row.gpu_ms).map(([k, v]) => `${k} ${(v.ms / runs).toFixed(3)} ms`).join(', ');
      console.log(`${row.case.padEnd(44)} ${row.pass ? 'pass' : 'FAIL'} ${r.passes}/${runs}` +
        (row.diagnosis ? `  ${row.check}: ${row.diagnosis}` : '') + (times ? `  [${times}]` : '') +
        (row.shrunk ? `\n${''.padEnd(44)} smallest failing: ${row.shrunk.id}${row.shrunk.diagnosis
          ? `: ${row.shrunk.diagnosis}` : ` (${row.shrunk.note})`}` : ''));
    }
  }
  const failed = results.filter((r) => !r.pass).length;
  const flaky = results.filter((r) => !r.pass && r.passes > 0).length;
  const quantum = timer.quantumNs();
  if (quantum !== null)
    console.log(`timestamps: resolution ${quantum} ns as the values show it (the gcd of every timestamp read)`);
  if (opts.prepareOnly || opts.dumpOnly) {
    console.log(`${opts.prepareOnly ? 'inputs' : 'dumps'} in ${root}`);
    return;
  }
  console.log(`${results.length - failed}/${results.length} cases pass on ${backend}` +
    (flaky ? ` (${flaky} flaky: passed some of ${opts.repeat} runs)` : '') +
    ` in ${((Date.now() - started) / 1000).toFixed(1)} s` + (warnings.length ? ` (${warnings.length} warning` +
    `${warnings.length > 1 ? 's' : ''}: ${warnings.join('; ')})` : ''));
  const found = patterns(results);
  for (const p of found) console.log(`pattern: ${p}`);
  // a sweep: per family and distribution, the sizes that pass and the ones that fail, as ranges
  const sweeps = [];
  for (const fam of opts.sweep ? opts.families : []) {
    for (const dist of [...new Set(results.filter((r) => r.family === fam).map((r) => r.params.dist))]) {
      const rows = results.filter((r) => r.family === fam && r.params.dist === dist);
      const bad = rows.filter((r) => !r.pass).map((r) => r.params.size);
      sweeps.push({family: fam, dist, sizes: rows.length, pass: rows.length - bad.length, failing: bad});
      console.log(`sweep ${fam}/${dist}: ${rows.length - bad.length} of ${rows.length} sizes pass` +
        (bad.length ? `; failing n: ${sizeRanges(bad)}` : ''));
    }
  }
  if (opts.sweep && opts.sweep.dropped.length)
    console.log(`sweep: n = ${sizeRanges(opts.sweep.dropped)} left out (above 2^25 keys, WebGPU's default ` +
      'storage-buffer limit)');
  const summary = {backend, adapter, repeat: opts.repeat, timestamps: timer.on, timestamp_quantum_ns: quantum,
    subset: opts.subset,
    families: opts.families, user_kernels: userKernels, warnings, patterns: found, sweeps, cases: results.length,
    failed, flaky, results};
  if (opts.json) fs.writeFileSync(opts.json, JSON.stringify(summary, null, 2) + '\n');
  if (opts.html) writeHtml(opts.html, summary);
  if (!opts.out) fs.rmSync(root, {recursive: true, force: true});
  process.exitCode = failed ? 1 : 0;
}

await main();

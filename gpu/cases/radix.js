// Case family "radix": the LSD radix sort (4-bit digits, tiles of 256 keys) over every distribution of DESIGN.md §3 x
// the matrix sizes. The GPU dumps the sorted keys with their source indices, the keys and source indices after every
// pass, and every pass's tile histograms, digit prefix and tile bases. check-sort validates the sort (sorted,
// permutation, stable) and the passes' keys; the stage tables and the passes' source indices are compared exactly
// with the oracle's radix bundle. The case reports the earliest stage that differs, in pipeline order (per pass:
// histogram, prefix, bases, scattered keys, their source indices), since every later stage inherits it.
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {readNpy, writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';
import {RADIX_BITS, RADIX_PASSES, RADIX_TILE, radixSort} from '../lib/sort.js';
import {sortCaseId, sortCases} from '../lib/matrix.js';

export const family = 'radix';

const RADIX = 1 << RADIX_BITS;
const ORACLE_ARGS = ['--algo', 'radix', '--radix-bits', String(RADIX_BITS), '--tile', String(RADIX_TILE)];

const caseOf = (dist, n, racy, sweep) => ({family, id: sortCaseId(family, dist, n, racy ? 'racy' : ''), dist, size: n,
  racy, sweep});

/** Every (distribution, size) of the matrix, or of --sweep; --racy-scatter plants the unsynchronised scatter in all
 * of them. */
export function list(opts) {
  return sortCases(opts, (dist, n, sweep) => caseOf(dist, n, opts.racyScatter, sweep));
}

/** The same case at another size (for --shrink). */
export function resize(c, n) {
  return caseOf(c.dist, n, c.racy, c.sweep);
}

const bits = (p) => `digit bits ${p * RADIX_BITS}..${p * RADIX_BITS + RADIX_BITS - 1}`;

/** The first (pass, stage) where the GPU's tables or scattered keys or values differ from the oracle bundle's, in
 * pipeline order, or null. Tables are (passes, tiles, digit) or (passes, digit); the scatter is (passes, n). A stable
 * scatter is unique, so even the source indices of equal keys must match. */
function firstDifference(bundle, gpu, tiles, n) {
  const stages = [
    {name: 'hist', file: 'radix_hist.npy', got: gpu.hist, width: tiles * RADIX},
    {name: 'prefix', file: 'radix_prefix.npy', got: gpu.prefix, width: RADIX},
    {name: 'base', file: 'radix_base.npy', got: gpu.base, width: tiles * RADIX},
    {name: 'scatter', file: 'radix_scatter.npy', got: gpu.passes, width: n},
    {name: 'perm', file: 'radix_perm.npy', got: gpu.passValues, width: n},
  ].map((s) => ({...s, want: bundle.npy(s.file).data}));
  for (let p = 0; p < RADIX_PASSES; p++) {
    for (const s of stages) {
      for (let x = p * s.width; x < (p + 1) * s.width; x++) {
        if (s.want[x] !== s.got[x]) return {...s, pass: p, at: x - p * s.width, want: s.want[x], got: s.got[x]};
      }
    }
  }
  return null;
}

/** A stage that diverged first as a case result, in the words of check-sort's pass fault, with check-sort's own
 * verdict on the final dump appended when it failed too. */
function stageResult(d, sorted) {
  const where = d.name === 'perm' ? `slot ${d.at}: expected source index`
    : `${d.name === 'prefix' ? '' : `tile ${Math.floor(d.at / RADIX)} `}digit ${d.at % RADIX}: expected`;
  return {pass: false, check: `radix-${d.name}`, fault: d.name, report: sorted.report,
    diagnosis: `${d.name}: radix pass ${d.pass} (${bits(d.pass)}) is the first to diverge, at ${where} ${d.want}, ` +
      `got ${d.got}${sorted.pass ? '' : ` (check-sort: ${sorted.diagnosis})`}`};
}

/** The input (keys.npy) and the oracle's radix bundle (oracle/) with every pass's tables. */
export function prepare(ctx, c) {
  const keys = path.join(ctx.dir, 'keys.npy');
  rtoracle(ctx.rtoracle, ['keys', '--dist', c.dist, '--n', String(c.size), '-o', keys]);
  if (!c.sweep) rtoracle(ctx.rtoracle, ['sort', keys, ...ORACLE_ARGS, '-o', path.join(ctx.dir, 'oracle')]);
}

/** The GPU's sorted keys and source indices, every pass's keys and indices, histograms, prefix and tile bases. */
export async function dump(ctx, c) {
  const gpu = await radixSort(ctx.device, readNpy(path.join(ctx.dir, 'keys.npy')).data,
    {timer: ctx.timer, racy: c.racy, passes: !c.sweep});
  const file = (name) => path.join(ctx.dumpDir, name);
  const n = c.size, tiles = gpu.tiles;
  writeNpy(file('sorted.npy'), gpu.keys);
  writeNpy(file('values.npy'), gpu.values);
  if (c.sweep) return; /* a sweep checks the final sort alone */
  writeNpy(file('passes.npy'), gpu.passes, [RADIX_PASSES, n]);
  writeNpy(file('pass_values.npy'), gpu.passValues, [RADIX_PASSES, n]);
  writeNpy(file('radix_hist.npy'), gpu.hist, [RADIX_PASSES, tiles, RADIX]);
  writeNpy(file('radix_prefix.npy'), gpu.prefix, [RADIX_PASSES, RADIX]);
  writeNpy(file('radix_base.npy'), gpu.base, [RADIX_PASSES, tiles, RADIX]);
}

export function validate(ctx, c) {
  const file = (name) => path.join(ctx.dumpDir, name);
  if (c.sweep)
    return {...check(ctx.rtoracle, 'check-sort', ['--input', path.join(ctx.dir, 'keys.npy'), '--gpu',
      file('sorted.npy'), '--gpu-values', file('values.npy'), '--stable', ...ORACLE_ARGS, '--no-artifacts']),
    check: 'check-sort'};
  const hist = readNpy(file('radix_hist.npy'));
  const gpu = {hist: hist.data, prefix: readNpy(file('radix_prefix.npy')).data,
    base: readNpy(file('radix_base.npy')).data, passes: readNpy(file('passes.npy')).data, passValues: readNpy(file('pass_values.npy')).data};
  const sorted = {...check(ctx.rtoracle, 'check-sort', ['--input', path.join(ctx.dir, 'keys.npy'),
    '--gpu', file('sorted.npy'), '--gpu-values', file('values.npy'), '--stable', ...ORACLE_ARGS,
    '--gpu-passes', file('passes.npy'), '--no-artifacts']), check: 'check-sort'};
  const first = firstDifference(new Bundle(path.join(ctx.dir, 'oracle')), gpu, hist.shape[1], c.size);
  // check-sort names the first pass whose keys diverge; a stage that diverges before that is the cause.
  return first && first.name !== 'scatter' ? stageResult(first, sorted) : sorted;
}

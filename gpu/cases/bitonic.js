// Case family "bitonic": the canonical network with one dispatch per (k, j) pass, over the sort matrix (every
// distribution of DESIGN.md §3 x sizes). rtoracle keys writes the input, the GPU sorts it and dumps its buffer and
// every pass, rtoracle check-sort validates both.
import fs from 'node:fs';
import path from 'node:path';
import {sortCaseId, sortCases} from '../lib/matrix.js';
import {readNpy, writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';
import {bitonicSort} from '../lib/sort.js';

export const family = 'bitonic';

/** Every (distribution, size) of the matrix, or of --sweep. */
export function list(opts) {
  return sortCases(opts, (dist, n, sweep) => resize({family, dist, sweep}, n));
}

/** The same case at another size (for --shrink). */
export function resize(c, n) {
  return {...c, id: sortCaseId(family, c.dist, n), size: n};
}

/** The oracle's input: keys.npy. */
export function prepare(ctx, c) {
  rtoracle(ctx.rtoracle, ['keys', '--dist', c.dist, '--n', String(c.size), '-o', path.join(ctx.dir, 'keys.npy')]);
}

/** The GPU's buffer after the sort (sorted.npy, n_padded slots) and after every pass (passes.npy). */
export async function dump(ctx, c) {
  const {sorted, passes, passTable} = await bitonicSort(ctx.device, readNpy(path.join(ctx.dir, 'keys.npy')).data,
    {dumpPasses: !c.sweep && c.size <= ctx.opts.passDumpLimit, timer: ctx.timer});
  writeNpy(path.join(ctx.dumpDir, 'sorted.npy'), sorted);
  if (passes) writeNpy(path.join(ctx.dumpDir, 'passes.npy'), passes, [passTable.length, sorted.length]);
}

export function validate(ctx) {
  const args = ['--input', path.join(ctx.dir, 'keys.npy'), '--gpu', path.join(ctx.dumpDir, 'sorted.npy'),
    '--no-artifacts'];
  const passes = path.join(ctx.dumpDir, 'passes.npy');
  if (fs.existsSync(passes)) args.push('--gpu-passes', passes);
  return {...check(ctx.rtoracle, 'check-sort', args), check: 'check-sort'};
}

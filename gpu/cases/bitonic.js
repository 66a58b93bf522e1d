// Case family "bitonic": the canonical network with one dispatch per (k, j) pass, over the sort matrix (every
// distribution of DESIGN.md §3 x sizes). rtoracle keys writes the input, the GPU sorts it and dumps its buffer and
// every pass, rtoracle check-sort validates both.
import path from 'node:path';
import {readNpy, writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';
import {bitonicSort} from '../lib/sort.js';
import {sortDists, sortSizes} from '../lib/matrix.js';

export const family = 'bitonic';

/** Every (distribution, size) of the matrix. */
export function list(opts) {
  return sortDists(opts).flatMap((dist) => sortSizes(opts).map((n) => ({family, id: `bitonic/${dist}/${n}`, dist, size: n})));
}

/** The same case at another size (for --shrink). */
export function resize(c, n) {
  return {...c, id: `bitonic/${c.dist}/${n}`, size: n};
}

export async function run(ctx, c) {
  const keysPath = path.join(ctx.dir, 'keys.npy');
  rtoracle(ctx.rtoracle, ['keys', '--dist', c.dist, '--n', String(c.size), '-o', keysPath]);
  const {sorted, passes, passTable} = await bitonicSort(ctx.device, readNpy(keysPath).data,
    {dumpPasses: c.size <= ctx.opts.passDumpLimit, timer: ctx.timer});
  const dump = path.join(ctx.dir, 'sorted.npy');
  writeNpy(dump, sorted);
  const args = ['--input', keysPath, '--gpu', dump, '--no-artifacts'];
  if (passes) {
    writeNpy(path.join(ctx.dir, 'passes.npy'), passes, [passTable.length, sorted.length]);
    args.push('--gpu-passes', path.join(ctx.dir, 'passes.npy'));
  }
  return {...check(ctx.rtoracle, 'check-sort', args), check: 'check-sort'};
}

// Case family "bitonic-wg": the canonical network in ONE workgroup with barriers between passes (the seeds'
// lbvhBuildMain shape), over every distribution of DESIGN.md §3 x the matrix sizes up to 16384. The kernel dumps the
// buffer after every pass, so check-sort names the first pass (k, j) and slot where a dropped barrier bites.
import path from 'node:path';
import {readNpy, writeNpy} from '../lib/npy.js';
import {check, rtoracle} from '../lib/oracle.js';
import {WG_MAX_KEYS, bitonicPasses, bitonicSortWg, padded} from '../lib/sort.js';
import {sortDists, sortSizes} from '../lib/matrix.js';

export const family = 'bitonic-wg';

/** Whether --drop-barrier P names a barrier of the network over n keys (there is one after passes 0 .. P - 2). */
const hasBarrier = (drop, n) => drop !== null && drop + 1 < bitonicPasses(padded(n)).length;

const caseOf = (dist, n, drop) => ({family, id: `bitonic-wg/${dist}/${n}${hasBarrier(drop, n) ? `/drop-${drop}` : ''}`,
  dist, size: n, dropBarrier: hasBarrier(drop, n) ? drop : null});

/** Every (distribution, size <= 16384) of the matrix; with --drop-barrier P, the sizes whose network has a barrier
 * after pass P run with it left out (the others run unchanged), and P beyond every size's network is bad usage. */
export function list(opts) {
  const sizes = sortSizes(opts).filter((n) => n <= WG_MAX_KEYS);
  const drop = opts.dropBarrier;
  if (drop !== null && !sizes.some((n) => hasBarrier(drop, n))) {
    console.error(`gpu/run: --drop-barrier ${drop}: no bitonic-wg size has a barrier after that pass ` +
      `(16384 keys have 105 passes, so 0 .. 103)`);
    process.exit(2);
  }
  return sortDists(opts).flatMap((dist) => sizes.map((n) => caseOf(dist, n, drop)));
}

/** The same case at another size (for --shrink); the dropped barrier stays where the smaller network has it. */
export function resize(c, n) {
  return caseOf(c.dist, n, c.dropBarrier);
}

export async function run(ctx, c) {
  const keysPath = path.join(ctx.dir, 'keys.npy');
  rtoracle(ctx.rtoracle, ['keys', '--dist', c.dist, '--n', String(c.size), '-o', keysPath]);
  const {sorted, passes, passTable} = await bitonicSortWg(ctx.device, readNpy(keysPath).data,
    {dumpPasses: c.size <= ctx.opts.passDumpLimit, timer: ctx.timer, dropBarrier: c.dropBarrier});
  const dump = path.join(ctx.dir, 'sorted.npy');
  writeNpy(dump, sorted);
  const args = ['--input', keysPath, '--gpu', dump, '--no-artifacts'];
  if (passes) {
    writeNpy(path.join(ctx.dir, 'passes.npy'), passes, [passTable.length, sorted.length]);
    args.push('--gpu-passes', path.join(ctx.dir, 'passes.npy'));
  }
  return {...check(ctx.rtoracle, 'check-sort', args), check: 'check-sort'};
}

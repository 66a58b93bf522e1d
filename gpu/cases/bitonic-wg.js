// Case family "bitonic-wg": the canonical network in ONE workgroup with barriers between passes (the seeds'
// lbvhBuildMain shape), over every distribution of DESIGN.md §3 x the matrix sizes up to 16384. The kernel dumps the
// buffer after every pass, so check-sort names the first pass (k, j) and slot where a dropped barrier bites.
import path from 'node:path';
import {readNpy, writeNpy} from '../lib/npy.js';
import {WG_MAX_KEYS, bitonicPasses, bitonicSortWg, padded} from '../lib/sort.js';
import {sortCaseId, sortDists, sortSizes} from '../lib/matrix.js';

export const family = 'bitonic-wg';

/** Whether --drop-barrier P names a barrier of the network over n keys (there is one after passes 0 .. P - 2). */
const hasBarrier = (drop, n) => drop !== null && drop + 1 < bitonicPasses(padded(n)).length;

const caseOf = (dist, n, drop) => ({family,
  id: sortCaseId(family, dist, n, hasBarrier(drop, n) ? `drop-${drop}` : ''),
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

// The input (keys.npy) and the checks (check-sort on sorted.npy and passes.npy) are the per-pass family's.
export {prepare, validate} from './bitonic.js';

/** The workgroup's buffer after the sort (sorted.npy) and after every pass (passes.npy). */
export async function dump(ctx, c) {
  const {sorted, passes, passTable} = await bitonicSortWg(ctx.device, readNpy(path.join(ctx.dir, 'keys.npy')).data,
    {dumpPasses: c.size <= ctx.opts.passDumpLimit, timer: ctx.timer, dropBarrier: c.dropBarrier});
  writeNpy(path.join(ctx.dumpDir, 'sorted.npy'), sorted);
  if (passes) writeNpy(path.join(ctx.dumpDir, 'passes.npy'), passes, [passTable.length, sorted.length]);
}

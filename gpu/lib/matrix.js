// The case matrix shared by the sort families (DESIGN.md §3): every u32 distribution and the issue's sizes.
export const SORT_DISTS = ['uniform', 'one-bucket', 'clustered', 'clustered-far', 'line', 'two-clusters', 'random',
  'entropy-1', 'entropy-3', 'entropy-9', 'entropy-15', 'sorted', 'reversed', 'all-equal', 'few-unique',
  'sentinel-heavy', 'digit-0-one-bucket', 'digit-1-one-bucket', 'digit-2-one-bucket', 'digit-3-one-bucket',
  'tile-overflow'];
export const SORT_SIZES = [1, 2, 3, 255, 256, 257, 4095, 4096, 4097, 16384, 65535];
/** The subset the test command runs on llvmpipe: the sizes up to 4097 but 3 and 4095 (2 and 4097 stand for them). */
export const CI_SORT_SIZES = SORT_SIZES.filter((n) => n <= 4097 && n !== 3 && n !== 4095);

/** A sort case's name: the directory name `rtoracle suite sort` gives the same case (ALGO-u32-DIST-nN; every GPU
 * family sorts u32 keys), with what the runner plants appended (-racy, -drop-P). It is also the case's directory. */
export function sortCaseId(family, dist, n, extra = '') {
  return `${family}-u32-${dist}-n${n}${extra ? `-${extra}` : ''}`;
}

/** The sizes of a sort family for the runner's options (explicit --sizes win, then the subset). */
export function sortSizes(opts) {
  return opts.sizes || (opts.subset === 'ci' ? CI_SORT_SIZES : SORT_SIZES);
}

export function sortDists(opts) {
  return opts.dists || SORT_DISTS;
}

/** The largest sweep size: WebGPU's default maxStorageBufferBindingSize (128 MiB) holds 2^25 u32 keys, and the
 * bitonic network pads n to a power of two. */
export const SWEEP_MAX_N = 1 << 25;

/** --sweep SPECS (comma-separated): tile:P every n in [P, 2P + 1]; pow2:K 2^k - 1, 2^k and 2^k + 1 for k = 1 .. K;
 * n:A-B every n in [A, B]. The sizes, sorted and unique, those above SWEEP_MAX_N left out ({sizes, dropped}); throws
 * on a bad spec. */
export function sweepSizes(spec) {
  const set = new Set();
  for (const part of spec.split(',').filter((x) => x.length)) {
    let m;
    const int = (x) => (/^\d+$/.test(x) ? Number(x) : NaN);
    if ((m = /^tile:(.+)$/.exec(part)) && int(m[1]) >= 1 && int(m[1]) <= SWEEP_MAX_N) {
      for (let n = int(m[1]); n <= 2 * int(m[1]) + 1; n++) set.add(n);
    } else if ((m = /^pow2:(.+)$/.exec(part)) && int(m[1]) >= 1 && int(m[1]) <= 25) {
      for (let k = 1; k <= int(m[1]); k++) [2 ** k - 1, 2 ** k, 2 ** k + 1].forEach((n) => set.add(n));
    } else if ((m = /^n:(\d+)-(\d+)$/.exec(part)) && int(m[1]) >= 1 && int(m[1]) <= int(m[2]) &&
               int(m[2]) - int(m[1]) < 1 << 20) {
      for (let n = int(m[1]); n <= int(m[2]); n++) set.add(n);
    } else {
      throw new Error(`--sweep: '${part}' is none of tile:P, pow2:K (K <= 25), n:A-B`);
    }
  }
  const all = [...set].sort((a, b) => a - b);
  return {sizes: all.filter((n) => n <= SWEEP_MAX_N), dropped: all.filter((n) => n > SWEEP_MAX_N)};
}

/** Sizes as ranges: [1, 2, 3, 7, 9, 10] -> "1-3, 7, 9-10". */
export function sizeRanges(sizes) {
  const out = [];
  for (let i = 0; i < sizes.length; i++) {
    let j = i;
    while (j + 1 < sizes.length && sizes[j + 1] === sizes[j] + 1) j++;
    out.push(j > i ? `${sizes[i]}-${sizes[j]}` : `${sizes[i]}`);
    i = j;
  }
  return out.join(', ');
}

/** The cases of a sort family: the matrix (every distribution x size), or with --sweep the sweep's sizes over the
 * given distributions (default random), marked sweep: keys made on the fly, only the final sort checked
 * (check-sort --input: no stored golden, no per-pass dumps). */
export function sortCases(opts, make) {
  if (opts.sweep) return (opts.dists || ['random']).flatMap((d) => opts.sweep.sizes.map((n) => make(d, n, true)));
  return sortDists(opts).flatMap((d) => sortSizes(opts).map((n) => make(d, n, false)));
}

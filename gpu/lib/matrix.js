// The case matrix shared by the sort families (DESIGN.md §3): every u32 distribution and the sizes.
export const SORT_DISTS = ['uniform', 'one-bucket', 'clustered', 'clustered-far', 'line', 'two-clusters', 'random',
  'entropy-1', 'entropy-3', 'entropy-9', 'entropy-15', 'sorted', 'reversed', 'all-equal', 'few-unique',
  'sentinel-heavy', 'digit-0-one-bucket', 'digit-1-one-bucket', 'digit-2-one-bucket', 'digit-3-one-bucket',
  'tile-overflow'];
export const SORT_SIZES = [1, 2, 3, 255, 256, 257, 4095, 4096, 4097, 16384, 65535];
/** The subset the test command runs on llvmpipe. */
export const CI_SORT_SIZES = SORT_SIZES.filter((n) => n <= 4097);

/** The sizes of a sort family for the runner's options (explicit --sizes win, then the subset). */
export function sortSizes(opts) {
  return opts.sizes || (opts.subset === 'ci' ? CI_SORT_SIZES : SORT_SIZES);
}

export function sortDists(opts) {
  return opts.dists || SORT_DISTS;
}

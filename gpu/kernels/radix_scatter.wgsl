// LSD radix, stage 3 of a pass (DESIGN.md §4): the stable scatter of one tile, carrying each key's value (its source
// index). Invocation t holds the tile's keys 2t and 2t + 1, so invocation order is input order. A key's slot is its
// tile's base for its digit plus its rank: how many keys of the same digit come before it in the tile. The ranks come
// from a scan over invocations of per-invocation digit counts, done for all RADIX digits at once.
// RACY_SCATTER (a define) replaces the ranks by the scatter this sort must not have: invocations claim slots with
// atomicAdd on a per-digit cursor, in whatever order the hardware serves them, so keys of equal digit leave the tile
// out of input order (stability, and with it every later LSD pass, is lost).
// #include "radix_common.wgsl"
@group(0) @binding(0) var<storage, read> keys_in: array<u32>;
@group(0) @binding(1) var<storage, read> vals_in: array<u32>;
@group(0) @binding(2) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> vals_out: array<u32>;
@group(0) @binding(4) var<storage, read> base: array<u32>; // (passes, tiles, RADIX)
@group(0) @binding(5) var<uniform> p: Params;

const NONE = RADIX; // the digit of a slot past the last key

// counts[d * WG + t]: this invocation's keys of digit d, then (after the scan) those of invocations 0 ..= t.
var<workgroup> counts: array<u32, RADIX * WG>;
var<workgroup> cursor: array<atomic<u32>, RADIX>; // RACY_SCATTER only

/** Inclusive scan of counts along the invocations, every digit at once (Hillis-Steele: log2(WG) steps). Each step
 * writes every element of `add`, from the invocation off places below or 0: nothing rests on a loop-local array being
 * zeroed again on each iteration. */
fn scan_counts(t: u32) {
  var add: array<u32, RADIX>;
  for (var off = 1u; off < WG; off <<= 1u) {
    let has = t >= off;
    let src = select(0u, t - off, has);
    for (var d = 0u; d < RADIX; d++) {
      add[d] = select(0u, counts[d * WG + src], has);
    }
    workgroupBarrier();
    for (var d = 0u; d < RADIX; d++) {
      counts[d * WG + t] += add[d];
    }
    workgroupBarrier();
  }
}

fn put(slot: u32, i: u32) {
  keys_out[slot] = keys_in[i];
  vals_out[slot] = vals_in[i];
}

@compute @workgroup_size(WG)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) t: u32) {
  let tile = wg.x + wg.y * nwg.x; // a 2-D grid past 65,535 tiles (gpu.js grid())
  if (tile >= p.tiles) { return; }
  let row = tile_row(p, tile);
  let i0 = tile * TILE + 2u * t;
  let i1 = i0 + 1u;
  let d0 = select(NONE, digit_of(keys_in[min(i0, p.n - 1u)], p.shift), i0 < p.n);
  let d1 = select(NONE, digit_of(keys_in[min(i1, p.n - 1u)], p.shift), i1 < p.n);
  if (RACY_SCATTER) {
    if (t < RADIX) {
      atomicStore(&cursor[t], base[row + t]);
    }
    workgroupBarrier();
    if (d0 != NONE) {
      put(atomicAdd(&cursor[d0], 1u), i0);
    }
    if (d1 != NONE) {
      put(atomicAdd(&cursor[d1], 1u), i1);
    }
    return;
  }
  for (var d = 0u; d < RADIX; d++) {
    counts[d * WG + t] = u32(d0 == d) + u32(d1 == d);
  }
  workgroupBarrier();
  scan_counts(t);
  // counts now includes this invocation's own keys: key 1 is the last of them, key 0 precedes key 1.
  if (d0 != NONE) {
    put(base[row + d0] + counts[d0 * WG + t] - 1u - u32(d1 == d0), i0);
  }
  if (d1 != NONE) {
    put(base[row + d1] + counts[d1 * WG + t] - 1u, i1);
  }
}

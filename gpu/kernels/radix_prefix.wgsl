// LSD radix, stage 2 of a pass (DESIGN.md §4): the exclusive prefix of the digit totals (the first output slot of
// each digit) and every tile's scatter base, base[t][d] = prefix[d] + sum of hist[t'][d] over tiles t' < t.
// One workgroup, invocation d walks digit d's column of tiles in order: a tile count is at most 65535, and walking
// keeps the sums in the oracle's order without a second scan.
// #include "radix_common.wgsl"
@group(0) @binding(0) var<storage, read> hist: array<u32>;
@group(0) @binding(1) var<storage, read_write> prefix: array<u32>; // (passes, RADIX)
@group(0) @binding(2) var<storage, read_write> base: array<u32>;   // (passes, tiles, RADIX)
@group(0) @binding(3) var<uniform> p: Params;

var<workgroup> totals: array<u32, RADIX>;

@compute @workgroup_size(RADIX)
fn main(@builtin(local_invocation_index) d: u32) {
  var total = 0u;
  for (var tile = 0u; tile < p.tiles; tile++) {
    total += hist[tile_row(p, tile) + d];
  }
  totals[d] = total;
  workgroupBarrier();
  var start = 0u;
  for (var e = 0u; e < d; e++) {
    start += totals[e];
  }
  prefix[p.pass_index * RADIX + d] = start;
  for (var tile = 0u; tile < p.tiles; tile++) {
    base[tile_row(p, tile) + d] = start;
    start += hist[tile_row(p, tile) + d];
  }
}

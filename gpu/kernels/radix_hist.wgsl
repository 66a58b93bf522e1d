// LSD radix, stage 1 of a pass (DESIGN.md §4): the digit histogram of each tile. One workgroup per tile; the counts
// go to hist (passes, tiles, RADIX) at this pass's row. Atomic increments only count, so their order is irrelevant.
// #include "radix_common.wgsl"
@group(0) @binding(0) var<storage, read> keys: array<u32>;
@group(0) @binding(1) var<storage, read_write> hist: array<u32>;
@group(0) @binding(2) var<uniform> p: Params;

var<workgroup> counts: array<atomic<u32>, RADIX>; // zero-initialised by WGSL

@compute @workgroup_size(WG)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) t: u32) {
  let tile = wg.x + wg.y * nwg.x; // a 2-D grid past 65,535 tiles (gpu.js grid())
  if (tile >= p.tiles) { return; }
  for (var i = tile * TILE + t; i < min(p.n, (tile + 1u) * TILE); i += WG) {
    atomicAdd(&counts[digit_of(keys[i], p.shift)], 1u);
  }
  workgroupBarrier();
  if (t < RADIX) {
    hist[tile_row(p, tile) + t] = atomicLoad(&counts[t]);
  }
}

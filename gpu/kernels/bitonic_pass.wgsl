// One compare-exchange pass (k, j) of the canonical bitonic network (DESIGN.md §4) over n_padded u32 keys: thread i
// pairs slot i with i ^ j when that partner is above it, and orders the pair ascending where bit k of i is 0.
struct Params { k: u32, j: u32, n: u32, pad: u32 }
@group(0) @binding(0) var<storage, read_write> keys: array<u32>;
@group(0) @binding(1) var<uniform> p: Params;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
  let i = gid.x + gid.y * nwg.x * 64u; // a 2-D grid past 65,535 workgroups (gpu.js grid())
  let l = i ^ p.j;
  if (i >= p.n || l <= i) { return; }
  let a = keys[i];
  let b = keys[l];
  let ascending = (i & p.k) == 0u;
  if ((ascending && a > b) || (!ascending && a < b)) {
    keys[i] = b;
    keys[l] = a;
  }
}

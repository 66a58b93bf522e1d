// splat_clear (seed 003): zero the density volume's u32 words, one thread per voxel word.
// #include "fluid_common.wgsl"

@group(0) @binding(0) var<uniform> counts: Counts;
@group(0) @binding(1) var<storage, read_write> vol: array<u32>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
  let i = linear_index(wg, nwg, lid);
  if (i >= counts.n) { return; }
  vol[i] = 0u;
}

// splat_resolve (seed 003, DESIGN.md §12.2): the fixed-point sums back to densities, density = f32(u) / scale, stored
// as (density, 0, 0, 1) in the rgba16float 3-D storage texture the raymarch samples (the binary16 rounding is the
// store's). One thread per voxel, 8x8x4 workgroups as the seed's.
// #include "fluid_common.wgsl"

@group(0) @binding(0) var<uniform> params: FluidParams;
@group(0) @binding(1) var<uniform> counts: Counts;
@group(0) @binding(2) var<storage, read> vol: array<u32>;
@group(0) @binding(3) var density: texture_storage_3d<rgba16float, write>;

@compute @workgroup_size(8, 8, 4)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
  if (g.x >= counts.nx || g.y >= counts.ny || g.z >= counts.nz) { return; }
  let u = vol[(g.z * counts.ny + g.y) * counts.nx + g.x];
  textureStore(density, g, vec4<f32>(f32(u) / params.scale, 0.0, 0.0, 1.0));
}

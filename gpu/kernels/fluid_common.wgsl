// The fluid kernels' uniform block: fluid_params.npy as rtoracle splat writes it (rto_fluid_uniforms, 16 f32, 64
// bytes, DESIGN.md §12.1), each value rounded once from binary64 on the host; and the harness's counts.

struct FluidParams {
  bounds_min: vec3<f32>,
  radius: f32,          // h
  voxel_size: vec3<f32>,
  kernel_factor: f32,   // S = 15 / (2 pi h^5)
  bounds_max: vec3<f32>,
  scale: f32,           // the fixed-point scale (1000)
  res: vec3<f32>,       // voxels per axis
  occupancy: f32,       // occupancy cells per axis (level 0)
}

// n: particles (or words to clear); nx, ny, nz: voxels per axis.
struct Counts { n: u32, nx: u32, ny: u32, nz: u32 }

// A thread's linear index over a 2-D grid of workgroups of 256 (gpu.js grid(): rows of 32,768 past 65,535).
fn linear_index(wg: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
  return (wg.x + wg.y * nwg.x) * 256u + lid;
}

// splat_particles (seed 003, DESIGN.md §12.2): one thread per particle adds the spiky pow2 kernel
// K(r) = (h - r)^2 * S, as the fixed-point integer u32(K * scale), to every voxel whose centre lies within the
// smoothing radius h, with atomicAdd (integer addition: exact and order-independent, wrapping mod 2^32 as the oracle's
// volume_u32.npy holds it). The arithmetic is §12.2's, in its order:
//   c = bounds_min + (f32(i) + 0.5) * voxel_size;  d = c - p;  r2 = (dx*dx + dy*dy) + dz*dz;  r = sqrt(r2)
//   r < h:  v = h - r;  k = (v * v) * S;  atomicAdd(vol[i], u32(k * scale))   (u32(f32) truncates toward zero)
// The voxels visited: the box of voxel indices floor((p -+ h - bounds_min) / voxel_size), one voxel larger on every
// side, clamped to the volume (a voxel outside the box cannot hold a centre within h).
// #include "fluid_common.wgsl"

@group(0) @binding(0) var<uniform> params: FluidParams;
@group(0) @binding(1) var<uniform> counts: Counts;
@group(0) @binding(2) var<storage, read> particles: array<f32>; // (N, 3)
@group(0) @binding(3) var<storage, read_write> vol: array<atomic<u32>>;

// The box's first and last voxel along one axis, clamped to [0, n - 1] (last < first: none). A non-finite or huge
// coordinate saturates in i32() (WGSL's conversion of an out-of-range f32 clamps) and clamps to an empty box.
fn box_lo(p: f32, h: f32, lo: f32, vs: f32) -> i32 {
  return max(i32(floor((p - h - lo) / vs)) - 1, 0);
}
fn box_hi(p: f32, h: f32, lo: f32, vs: f32, n: u32) -> i32 {
  return min(i32(floor((p + h - lo) / vs)) + 1, i32(n) - 1);
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
  let id = linear_index(wg, nwg, lid);
  if (id >= counts.n) { return; }
  let p = vec3<f32>(particles[3u * id], particles[3u * id + 1u], particles[3u * id + 2u]);
  let h = params.radius;
  let lo = params.bounds_min;
  let vs = params.voxel_size;
  if (!(abs(p.x) < 3.0e38 && abs(p.y) < 3.0e38 && abs(p.z) < 3.0e38)) { return; } // NaN or infinite: no voxel
  let x0 = box_lo(p.x, h, lo.x, vs.x);
  let y0 = box_lo(p.y, h, lo.y, vs.y);
  let z0 = box_lo(p.z, h, lo.z, vs.z);
  let x1 = box_hi(p.x, h, lo.x, vs.x, counts.nx);
  let y1 = box_hi(p.y, h, lo.y, vs.y, counts.ny);
  let z1 = box_hi(p.z, h, lo.z, vs.z, counts.nz);
  for (var z = z0; z <= z1; z++) {
    let cz = lo.z + (f32(z) + 0.5) * vs.z;
    let dz = cz - p.z;
    for (var y = y0; y <= y1; y++) {
      let cy = lo.y + (f32(y) + 0.5) * vs.y;
      let dy = cy - p.y;
      for (var x = x0; x <= x1; x++) {
        let cx = lo.x + (f32(x) + 0.5) * vs.x;
        let dx = cx - p.x;
        let r2 = (dx * dx + dy * dy) + dz * dz;
        let r = sqrt(r2);
        if (r < h) {
          let v = h - r;
          let k = (v * v) * params.kernel_factor;
          let i = (u32(z) * counts.ny + u32(y)) * counts.nx + u32(x);
          atomicAdd(&vol[i], u32(k * params.scale));
        }
      }
    }
  }
}

// The occupancy grid for empty-space skipping (DESIGN.md §12.3), built from the particles: O cells per axis over the
// bounds (O = params.occupancy), cell size cs = (bounds_max - bounds_min) / O. Level 0 bit b = (z*O + y)*O + x is
// word b >> 5, bit b & 31; level l + 1 has ceil(res_l / 2) cells per axis, a cell set iff any of its (up to 8)
// children is, down to 1 cell; the levels follow each other in one buffer (word offsets from the bundle's manifest).
// Entry points:
//   clear  zero every word (one thread a word)
//   main   level 0, one thread per particle: every cell whose box meets [p - R, p + R] per axis,
//          R = h * (1 + 2^-12) + voxel_size (the kernel's radius dilated by one voxel for trilinear reads), set by
//          atomicOr. The oracle computes the cell range in binary64; here it is binary32, widened by 2^-8 of a cell on
//          each side so that its rounding can only add cells (a superset stays lossless).
//   mip    level l + 1 from level l: one thread per word of the parent level, its 32 cells each the OR of their
//          children (a plain store: the thread owns the word).
// #include "fluid_common.wgsl"

@group(0) @binding(0) var<uniform> params: FluidParams;
@group(0) @binding(1) var<uniform> counts: Counts;
@group(0) @binding(2) var<storage, read> particles: array<f32>;
@group(0) @binding(3) var<storage, read_write> occ: array<atomic<u32>>;

// mip: the child level's cells per axis and first word, the parent's.
struct Level { res_child: u32, off_child: u32, res_parent: u32, off_parent: u32 }
@group(0) @binding(4) var<uniform> level: Level;
@group(0) @binding(5) var<storage, read_write> words: array<u32>;

@compute @workgroup_size(256)
fn clear(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
         @builtin(local_invocation_index) lid: u32) {
  let i = linear_index(wg, nwg, lid);
  if (i >= counts.n) { return; }
  words[i] = 0u;
}

// The cells [first, last] along one axis (clamped to [0, o - 1]; last < first: none): c with
// lo + c * cs <= p + R and lo + (c + 1) * cs >= p - R.
fn cell_range(p: f32, r: f32, lo: f32, hi: f32, o: u32) -> vec2<i32> {
  let cs = (hi - lo) / f32(o);
  let t0 = (p - r - lo) / cs - 1.0 / 256.0;
  let t1 = (p + r - lo) / cs + 1.0 / 256.0;
  return vec2<i32>(max(i32(ceil(t0)) - 1, 0), min(i32(floor(t1)), i32(o) - 1));
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
  let id = linear_index(wg, nwg, lid);
  if (id >= counts.n) { return; }
  let p = vec3<f32>(particles[3u * id], particles[3u * id + 1u], particles[3u * id + 2u]);
  if (!(abs(p.x) < 3.0e38 && abs(p.y) < 3.0e38 && abs(p.z) < 3.0e38)) { return; }
  let o = u32(params.occupancy);
  let hr = params.radius * (1.0 + 1.0 / 4096.0);
  let r = hr + params.voxel_size;
  let xs = cell_range(p.x, r.x, params.bounds_min.x, params.bounds_max.x, o);
  let ys = cell_range(p.y, r.y, params.bounds_min.y, params.bounds_max.y, o);
  let zs = cell_range(p.z, r.z, params.bounds_min.z, params.bounds_max.z, o);
  for (var z = zs.x; z <= zs.y; z++) {
    for (var y = ys.x; y <= ys.y; y++) {
      for (var x = xs.x; x <= xs.y; x++) {
        let b = (u32(z) * o + u32(y)) * o + u32(x);
        atomicOr(&occ[b >> 5u], 1u << (b & 31u));
      }
    }
  }
}

fn child_bit(x: u32, y: u32, z: u32) -> u32 {
  let n = level.res_child;
  if (x >= n || y >= n || z >= n) { return 0u; }
  let b = (z * n + y) * n + x;
  return (words[level.off_child + (b >> 5u)] >> (b & 31u)) & 1u;
}

@compute @workgroup_size(256)
fn mip(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
       @builtin(local_invocation_index) lid: u32) {
  let w = linear_index(wg, nwg, lid);
  let n = level.res_parent;
  let cells = n * n * n;
  if (w * 32u >= cells) { return; }
  var word = 0u;
  for (var j = 0u; j < 32u; j++) {
    let b = w * 32u + j;
    if (b >= cells) { break; }
    let x = b % n;
    let y = (b / n) % n;
    let z = b / (n * n);
    var hit = 0u;
    for (var c = 0u; c < 8u; c++) {
      hit |= child_bit(2u * x + (c & 1u), 2u * y + ((c >> 1u) & 1u), 2u * z + (c >> 2u));
    }
    word |= hit << j;
  }
  words[level.off_parent + w] = word;
}

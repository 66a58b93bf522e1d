// The raymarch of seed 003 (DESIGN.md §12.4-§12.5) as a compute kernel: the reference's operations in its order
// (src/fluid/raymarch.c), one thread per pixel, 8x8 workgroups, entry point main. What the oracle checks it against:
// rtoracle check-raymarch (§12.7) with the dump image.npy, crossing.npy, steps.npy / steps_skip.npy,
// crossing_noskip.npy (gpu/cases/fluid.js runs it twice, rm_params[58] = the bundle's skip flag, then 0).
//
// Bindings (group 0):
//   0  params      uniform RmParams: rm_params.npy, f32 (64,), 256 bytes, = rto_raymarch_uniforms (below)
//   1  density     texture_3d<f32>: rgba16float, (nx, ny, nz), density in R (volume_f16.npy uploaded as it is)
//   2  samp        sampler: linear min/mag/mip filtering, clamp-to-edge on u, v, w
//   3  occ         storage, read, array<u32>: occupancy.npy, every level (level l at word level_offset(l), each level
//                  ceil(res_l^3 / 32) words, res_0 = O, res_l+1 = ceil(res_l / 2) down to 1; bit b = (z*R + y)*R + x
//                  is word b >> 5, bit b & 31)
//   4  image       storage, read_write, array<vec4<f32>>: (H, W) row-major, (r, g, b, 1)
//   5  crossing    storage, read_write, array<u32>: the first crossing's step index k, 0xFFFFFFFF for none
//   6  steps       storage, read_write, array<u32>: primary-march loop iterations, all bounces (a skip counts one)
//
// Uniform layout (rto_raymarch_uniforms, f32 index: field). Integers are exact floats except jitter_seed (u32 bits):
//    0..15  inverse_projection (mat4x4, column-major: [4c + r] = column c, row r)
//   16..31  inverse_view
//   32..34  eye (camera position)          35  step_size
//   36..38  bounds_min                     39  light_step_size (the shadow march steps 2x it)
//   40..42  bounds_max                     43  density_offset
//   44..46  extinction (rgb)               47  density_multiplier
//   48..50  sun_dir (towards the sun, unit) 51 ior (1.33)
//   52  floor_height   53  num_refractions   54  jitter_scale (0.4)   55  jitter_seed (u32 bits)
//   56  width          57  height            58  skip (1: empty-space skipping)   59  occupancy (O, cells per axis)
//   60..62  res (voxels per axis)          63  occupancy_levels
//
// Differences a conforming device may show and the check admits (§12.5.1): the hardware's trilinear weights (8
// fractional bits), fused multiply-adds, exp / sqrt / division within WGSL's accuracy, the skip jump computed in f32
// here (binary64 in the reference: steps_skip may differ, never below the samples in occupied cells).

struct RmParams {
  inverse_projection: mat4x4<f32>,
  inverse_view: mat4x4<f32>,
  eye: vec3<f32>,
  step_size: f32,
  bounds_min: vec3<f32>,
  light_step_size: f32,
  bounds_max: vec3<f32>,
  density_offset: f32,
  extinction: vec3<f32>,
  density_multiplier: f32,
  sun_dir: vec3<f32>,
  ior: f32,
  floor_height: f32,
  num_refractions: f32,
  jitter_scale: f32,
  jitter_seed: u32,
  width: f32,
  height: f32,
  skip: f32,
  occupancy: f32,
  res: vec3<f32>,
  occupancy_levels: f32,
}

@group(0) @binding(0) var<uniform> params: RmParams;
@group(0) @binding(1) var density: texture_3d<f32>;
@group(0) @binding(2) var samp: sampler;
@group(0) @binding(3) var<storage, read> occ: array<u32>;
@group(0) @binding(4) var<storage, read_write> image: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> crossing: array<u32>;
@group(0) @binding(6) var<storage, read_write> steps: array<u32>;

const NONE: u32 = 0xFFFFFFFFu;
const MAX_STEPS: u32 = 512u;
const SHADOW_STEPS: u32 = 32u;
const SHADOW_EXIT: f32 = 3.0;
const SHORT_MAX: f32 = 2.0;
const EPS: f32 = 1.0e-4;
const INF: f32 = 3.0e38;

// Per-thread state.
var<private> g_steps: u32;
var<private> g_pixel: u32;
var<private> g_lres: array<u32, 12>;
var<private> g_loff: array<u32, 12>;

// The PRNG of DESIGN.md §3: unit(seed, i) = (h(i ^ h(seed)) >> 8) * 2^-24.
fn hash32(v: u32) -> u32 {
  var x = v;
  x ^= x >> 16u;
  x *= 0x7feb352du;
  x ^= x >> 15u;
  x *= 0x846ca68bu;
  x ^= x >> 16u;
  return x;
}
fn unit(seed: u32, i: u32) -> f32 {
  return f32(hash32(i ^ hash32(seed)) >> 8u) * (1.0 / 16777216.0);
}

// The density at q: (trilinear - offset) * multiplier; -offset * multiplier outside [eps, 1 - eps].
fn sample_density(q: vec3<f32>) -> f32 {
  let uvw = (q - params.bounds_min) / (params.bounds_max - params.bounds_min);
  if (any(uvw >= vec3<f32>(1.0 - EPS)) || any(uvw <= vec3<f32>(EPS))) {
    return -params.density_offset * params.density_multiplier;
  }
  let t = textureSampleLevel(density, samp, uvw, 0.0).r;
  return (t - params.density_offset) * params.density_multiplier;
}

// Slab test: (t0, t1, hit).
fn ray_box(o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
  var tn = -INF;
  var tf = INF;
  for (var a = 0; a < 3; a++) {
    let inv = 1.0 / d[a];
    let ta = (params.bounds_min[a] - o[a]) * inv;
    let tb = (params.bounds_max[a] - o[a]) * inv;
    tn = max(tn, min(ta, tb));
    tf = min(tf, max(ta, tb));
  }
  return vec3<f32>(tn, tf, select(0.0, 1.0, tf > max(tn, 0.0)));
}

fn occ_get(l: u32, x: u32, y: u32, z: u32) -> bool {
  let r = g_lres[l];
  let b = (z * r + y) * r + x;
  let w = g_loff[l] + (b >> 5u);
  if (w >= arrayLength(&occ)) { return true; }
  return ((occ[w] >> (b & 31u)) & 1u) != 0u;
}

// Empty-space skipping (§12.5): the next sample index to take from sample k at p (k itself when p's cell is occupied).
fn skip_to(o: vec3<f32>, d: vec3<f32>, p: vec3<f32>, tb: f32, step: f32, k: u32, kmax: u32) -> u32 {
  let O = u32(params.occupancy);
  let ext = params.bounds_max - params.bounds_min;
  let cs = ext / f32(O);
  var c: vec3<u32>;
  for (var a = 0; a < 3; a++) {
    if (!(p[a] >= params.bounds_min[a] && p[a] <= params.bounds_max[a])) { return k; }
    let cc = clamp(floor((p[a] - params.bounds_min[a]) / cs[a]), 0.0, f32(O - 1u));
    c[a] = u32(cc);
  }
  if (occ_get(0u, c.x, c.y, c.z)) { return k; }
  var L = 0u;
  let levels = u32(params.occupancy_levels);
  while (L + 1u < levels && !occ_get(L + 1u, c.x >> (L + 1u), c.y >> (L + 1u), c.z >> (L + 1u))) { L++; }
  let omax = max(max(abs(o.x), abs(o.y)), abs(o.z));
  let bmag = max(max(max(abs(params.bounds_min.x), abs(params.bounds_min.y)), abs(params.bounds_min.z)),
                 max(max(abs(params.bounds_max.x), abs(params.bounds_max.y)), abs(params.bounds_max.z)));
  let tk = tb + f32(k) * step;
  // The reference's margin (2^-20) and 2^-16 of a cell more for this f32 arithmetic: the jump can only shorten.
  let m = (omax + abs(tk) + bmag) * (1.0 / 1048576.0);
  var texit = INF;
  for (var a = 0; a < 3; a++) {
    if (d[a] == 0.0) { continue; }
    let first = (c[a] >> L) << L;
    let last = min(((c[a] >> L) + 1u) << L, O);
    let lo = params.bounds_min[a] + f32(first) * cs[a] + m + cs[a] * (1.0 / 65536.0);
    let hi = params.bounds_min[a] + f32(last) * cs[a] - m - cs[a] * (1.0 / 65536.0);
    let te = (select(lo, hi, d[a] > 0.0) - o[a]) / d[a];
    texit = min(texit, te);
  }
  var kn = floor((texit - tb) / step);
  if (!(kn < f32(kmax))) { kn = f32(kmax); }
  var k2 = k;
  if (kn > f32(k)) { k2 = u32(kn); }
  return max(k2, k + 1u);
}

struct Hit { found: bool, k: u32, t: f32, p: vec3<f32>, depth: f32 }

// findNextSurface (§12.4).
fn search(o: vec3<f32>, d: vec3<f32>, exiting: bool, primary: bool) -> Hit {
  var h = Hit(false, 0u, 0.0, vec3<f32>(0.0), 0.0);
  let bx = ray_box(o, d);
  if (bx.z == 0.0) { return h; }
  let step = params.step_size;
  var tb = max(bx.x, 0.0);
  if (primary) { tb = tb + (unit(params.jitter_seed, g_pixel) * step) * params.jitter_scale; }
  var k = select(1u, 0u, primary);
  loop {
    if (k >= MAX_STEPS) { break; }
    let t = tb + f32(k) * step;
    if (!(t < bx.y)) { break; }
    let p = o + d * t;
    g_steps++;
    if (params.skip != 0.0 && !exiting) {
      let k2 = skip_to(o, d, p, tb, step, k, MAX_STEPS);
      if (k2 != k) { k = k2; continue; }
    }
    let v = sample_density(p);
    if ((exiting && v < 0.0) || (!exiting && v > 0.0)) {
      h.found = true;
      h.k = k;
      h.t = t;
      h.p = p;
      return h;
    }
    if (exiting) { h.depth = h.depth + v * step; }
    k++;
  }
  return h;
}

// The shadow march (§12.4): 2 x lightStepSize, sample indices 0 .. 31, early exit at optical depth > 3.
fn shadow_depth(o: vec3<f32>, d: vec3<f32>) -> f32 {
  let bx = ray_box(o, d);
  if (bx.z == 0.0) { return 0.0; }
  let step2 = params.light_step_size * 2.0;
  let tb = max(bx.x, 0.0);
  var depth = 0.0;
  var k = 0u;
  loop {
    if (k >= SHADOW_STEPS) { break; }
    let t = tb + f32(k) * step2;
    if (!(t < bx.y)) { break; }
    let p = o + d * t;
    if (params.skip != 0.0) {
      let k2 = skip_to(o, d, p, tb, step2, k, SHADOW_STEPS);
      if (k2 != k) { k = k2; continue; }
    }
    depth = depth + max(sample_density(p), 0.0) * step2;
    if (depth > SHADOW_EXIT) { break; }
    k++;
  }
  return depth;
}

// The refraction heuristic's 4-sample march over [max(t0, 0), min(t1, 2)].
fn short_depth(o: vec3<f32>, d: vec3<f32>) -> f32 {
  let bx = ray_box(o, d);
  if (bx.z == 0.0) { return 0.0; }
  let ts = max(bx.x, 0.0);
  let te = min(bx.y, SHORT_MAX);
  if (!(te > ts)) { return 0.0; }
  let seg = (te - ts) * 0.25;
  var depth = 0.0;
  for (var i = 0u; i < 4u; i++) {
    depth = depth + max(sample_density(o + d * (ts + (f32(i) + 0.5) * seg)), 0.0) * seg;
  }
  return depth;
}

// The environment: a checkered floor (2 squares a unit) lit through the fluid's shadow, or the sky with a sun.
fn environment(o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
  if (d.y < 0.0) {
    let tf = (params.floor_height - o.y) / d.y;
    if (tf > 0.0) {
      let fx = o.x + d.x * tf;
      let fz = o.z + d.z * tf;
      if (abs(fx) < 1.0e4 && abs(fz) < 1.0e4) {
        let parity = (i32(floor(fx * 2.0)) + i32(floor(fz * 2.0))) & 1;
        let base = select(vec3<f32>(0.35, 0.35, 0.4), vec3<f32>(0.85, 0.85, 0.8), parity != 0);
        let sd = shadow_depth(vec3<f32>(fx, params.floor_height, fz), params.sun_dir);
        let lit = 0.65 * max(params.sun_dir.y, 0.0);
        let sT = exp(-(sd * params.extinction));
        return base * (0.35 + lit * sT);
      }
    }
  }
  let a = sqrt(max(d.y, 0.0));
  var s = max(dot(d, params.sun_dir), 0.0);
  for (var i = 0; i < 9; i++) { s = s * s; }
  let hor = vec3<f32>(0.8, 0.85, 0.9);
  let zen = vec3<f32>(0.2, 0.45, 0.85);
  return (hor + (zen - hor) * a) + s * 4.0;
}

// n = -grad / |grad| by central differences, one voxel on each axis; (0, 1, 0) where the gradient is 0.
fn normal_central(p: vec3<f32>) -> vec3<f32> {
  let vs = (params.bounds_max - params.bounds_min) / params.res;
  var g: vec3<f32>;
  for (var a = 0; a < 3; a++) {
    var e = vec3<f32>(0.0);
    e[a] = vs[a];
    g[a] = sample_density(p + e) - sample_density(p - e);
  }
  let len2 = dot(g, g);
  if (!(len2 > 0.0)) { return vec3<f32>(0.0, 1.0, 0.0); }
  return -(g / sqrt(len2));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
  let W = u32(params.width);
  let H = u32(params.height);
  if (gid.x >= W || gid.y >= H) { return; }
  // The occupancy levels (§12.3).
  var r = u32(params.occupancy);
  var off = 0u;
  for (var l = 0u; l < 12u; l++) {
    g_lres[l] = r;
    g_loff[l] = off;
    off += (r * r * r + 31u) / 32u;
    r = (r + 1u) / 2u;
  }
  g_pixel = gid.y * W + gid.x;
  g_steps = 0u;
  // The primary ray (rto_camera_ray, seed 002's generateRay).
  let px = f32(gid.x) + 0.5;
  let py = f32(gid.y) + 0.5;
  let nx = (px / params.width) * 2.0 - 1.0;
  let ny = 1.0 - (py / params.height) * 2.0;
  let ip = params.inverse_projection;
  let iv = params.inverse_view;
  var eye: vec2<f32>;
  for (var i = 0; i < 2; i++) {
    eye[i] = ((ip[0][i] * nx + ip[1][i] * ny) + ip[2][i] * -1.0) + ip[3][i] * 1.0;
  }
  var world: vec3<f32>;
  for (var i = 0; i < 3; i++) {
    world[i] = ((iv[0][i] * eye.x + iv[1][i] * eye.y) + iv[2][i] * -1.0) + iv[3][i] * 0.0;
  }
  var dir = world / sqrt((world.x * world.x + world.y * world.y) + world.z * world.z);
  var pos = params.eye;
  var T = vec3<f32>(1.0);
  var L = vec3<f32>(0.0);
  var inside = false;
  let ior = params.ior;
  var r0 = (1.0 - ior) / (1.0 + ior);
  r0 = r0 * r0;
  var first = NONE;
  let bounces = u32(params.num_refractions);
  for (var b = 0u; b < bounces; b++) {
    let h = search(pos, dir, inside, b == 0u);
    if (!h.found) { break; }
    if (b == 0u) { first = h.k; }
    T = T * exp(-(h.depth * params.extinction));
    var n = normal_central(h.p);
    if (dot(n, dir) > 0.0) { n = -n; }
    let entering = !inside;
    let eta = select(ior, 1.0 / ior, entering);
    let cosi = -dot(n, dir);
    let refl = dir + (2.0 * cosi) * n;
    let sin2t = (eta * eta) * (1.0 - cosi * cosi);
    let tir = sin2t > 1.0;
    var refr = vec3<f32>(0.0);
    var cost = 0.0;
    var R = 1.0;
    if (!tir) {
      cost = sqrt(1.0 - sin2t);
      refr = eta * dir + (eta * cosi - cost) * n;
      let xx = 1.0 - select(cost, cosi, entering);
      let x5 = ((xx * xx) * (xx * xx)) * xx;
      R = r0 + (1.0 - r0) * x5;
    }
    let Tr = 1.0 - R;
    var dRefr = 0.0;
    if (!tir) { dRefr = short_depth(h.p, refr); }
    let dRefl = short_depth(h.p, refl);
    if (dRefr * Tr > dRefl * R) {
      L = L + ((environment(h.p, refl) * T) * exp(-(dRefl * params.extinction))) * R;
      dir = refr;
      T = T * Tr;
      inside = !inside;
    } else {
      if (!tir) {
        L = L + ((environment(h.p, refr) * T) * exp(-(dRefr * params.extinction))) * Tr;
      }
      dir = refl;
      T = T * R;
    }
    pos = h.p;
    if (all(T < vec3<f32>(0.01))) { break; }
  }
  let rem = shadow_depth(pos, dir);
  L = L + (environment(pos, dir) * T) * exp(-(rem * params.extinction));
  image[g_pixel] = vec4<f32>(L, 1.0);
  crossing[g_pixel] = first;
  steps[g_pixel] = g_steps;
}

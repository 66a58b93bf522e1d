// TLAS keys of instances (DESIGN.md §3 and §5, docs/bvh.md "Primitive boxes"), three entry points of one stage:
//   instance_boxes   each instance's world AABB: its BLAS's object box, all 8 corners through objToWorld
//   centroid_bounds  lo / hi of the centroids of the non-empty boxes (one workgroup, a fixed reduction tree)
//   morton_keys      (morton15 << 16) | index per keyed instance, the sentinel for the rest of the sort buffer
// The arithmetic is written in the oracle's order (src/keys/box_keys.c, src/keys/morton.c) so that a device that
// neither fuses multiply-adds nor approximates division reproduces its bytes.

const SENTINEL = 0xFFFFFFFFu;
const WG = 64u;

// InstanceRecord, 128 bytes (DESIGN.md §5): 3x4 row-major matrices.
struct Instance {
  objToWorld: array<f32, 12>,
  worldToObj: array<f32, 12>,
  blas: u32, customIndex: u32, mask: u32, sbtOffset: u32, flags: u32, pad0: u32, pad1: u32, pad2: u32,
}

// Where mesh M's object box lies in `blas`: `at` is the word offset of its root BlasNode (2 or more triangles, the
// box is the union of the root's two child boxes) or of its single triangle's Aabb (min.xyz, max.xyz; one triangle,
// a BLAS without internal nodes); a mesh of 0 triangles is an empty BLAS.
struct Mesh { at: u32, triangles: u32 }

struct Aabb { lo: vec3<f32>, hi: vec3<f32> }

struct Params { n: u32, slots: u32, pad0: u32, pad1: u32 }  // instances, sort-buffer slots (a power of two >= n)

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> instances: array<Instance>;
@group(0) @binding(2) var<storage, read> meshes: array<Mesh>;
@group(0) @binding(3) var<storage, read> blas: array<f32>;
@group(0) @binding(4) var<storage, read_write> boxes: array<Aabb>;
@group(0) @binding(5) var<storage, read_write> bounds: array<vec4<f32>, 2>;  // lo, hi (w unused)
@group(0) @binding(6) var<storage, read_write> keys: array<u32>;

// The oracle's min / max (rto__minf / rto__maxf): the second operand when both compare equal, so the sign of a zero
// is the same as on the CPU; WGSL's min() / max() leave that choice to the implementation.
fn minf(a: f32, b: f32) -> f32 { return select(b, a, a < b); }
fn maxf(a: f32, b: f32) -> f32 { return select(b, a, a > b); }
fn min3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> { return vec3(minf(a.x, b.x), minf(a.y, b.y), minf(a.z, b.z)); }
fn max3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> { return vec3(maxf(a.x, b.x), maxf(a.y, b.y), maxf(a.z, b.z)); }

fn vec_at(w: u32) -> vec3<f32> { return vec3(blas[w], blas[w + 1u], blas[w + 2u]); }

// +inf, built at run time: a constant expression may not evaluate to an infinity.
var<private> INF_BITS: u32 = 0x7f800000u;
fn inf() -> f32 { return bitcast<f32>(INF_BITS); }
fn empty_box() -> Aabb { return Aabb(vec3(inf()), vec3(-inf())); }

// Strict comparisons, as rto_aabb_is_empty: a NaN bound is not "empty".
fn is_empty(b: Aabb) -> bool { return any(b.lo > b.hi); }

// The object box of mesh m from its BLAS: the root's child boxes (lmin at word 0, lmax 4, rmin 8, rmax 12).
fn object_box(m: u32) -> Aabb {
  let mesh = meshes[m];
  if (mesh.triangles == 0u) { return empty_box(); }
  if (mesh.triangles == 1u) { return Aabb(vec_at(mesh.at), vec_at(mesh.at + 3u)); }
  return Aabb(min3(vec_at(mesh.at), vec_at(mesh.at + 8u)), max3(vec_at(mesh.at + 4u), vec_at(mesh.at + 12u)));
}

// One row of a 3x4 transform, translation last: ((m0*x + m1*y) + m2*z) + m3 (DESIGN.md §6).
fn row(m: array<f32, 12>, r: u32, q: vec3<f32>) -> f32 {
  let a = m[4u * r] * q.x;
  let b = m[4u * r + 1u] * q.y;
  let c = m[4u * r + 2u] * q.z;
  return ((a + b) + c) + m[4u * r + 3u];
}

@compute @workgroup_size(WG)
fn instance_boxes(@builtin(global_invocation_id) gid: vec3<u32>) {
  let i = gid.x;
  if (i >= p.n) { return; }
  let inst = instances[i];
  let ob = object_box(inst.blas);
  // rto_aabb_transform: an empty (or NaN) object box stays empty, its +-inf corners would give NaN.
  if (!all(ob.lo <= ob.hi)) {
    boxes[i] = empty_box();
    return;
  }
  var w = empty_box();
  for (var c = 0u; c < 8u; c++) {  // the oracle's corner order: bit 0 picks x, bit 1 y, bit 2 z
    let q = select(ob.lo, ob.hi, vec3((c & 1u) != 0u, (c & 2u) != 0u, (c & 4u) != 0u));
    let t = vec3(row(inst.objToWorld, 0u, q), row(inst.objToWorld, 1u, q), row(inst.objToWorld, 2u, q));
    w = Aabb(min3(w.lo, t), max3(w.hi, t));
  }
  boxes[i] = w;
}

fn centroid(b: Aabb) -> vec3<f32> { return (b.lo + b.hi) * 0.5; }

var<workgroup> wlo: array<vec3<f32>, WG>;
var<workgroup> whi: array<vec3<f32>, WG>;

// One workgroup: thread t takes instances t, t + WG, ... (a static partition), then a halving tree merges the
// partial bounds. min / max of floats is exact, so the order changes nothing but the sign of a zero bound, which
// changes no key (c - lo and hi - lo are the same numbers either way, and -0 == +0 in the hi == lo test).
@compute @workgroup_size(WG)
fn centroid_bounds(@builtin(local_invocation_index) t: u32) {
  var lo = vec3(inf());
  var hi = vec3(-inf());
  for (var i = t; i < p.n; i += WG) {
    let b = boxes[i];
    if (is_empty(b)) { continue; }  // an instance of an empty BLAS has no centroid (§5)
    let c = centroid(b);
    lo = vec3(select(lo.x, c.x, c.x < lo.x), select(lo.y, c.y, c.y < lo.y), select(lo.z, c.z, c.z < lo.z));
    hi = vec3(select(hi.x, c.x, c.x > hi.x), select(hi.y, c.y, c.y > hi.y), select(hi.z, c.z, c.z > hi.z));
  }
  wlo[t] = lo;
  whi[t] = hi;
  for (var s = WG / 2u; s > 0u; s >>= 1u) {
    workgroupBarrier();
    if (t < s) {
      wlo[t] = min3(wlo[t], wlo[t + s]);
      whi[t] = max3(whi[t], whi[t + s]);
    }
  }
  if (t == 0u) {
    bounds[0] = vec4(wlo[0], 0.0);
    bounds[1] = vec4(whi[0], 0.0);
  }
}

// q = min(31, u32(floor(((c - lo) / (hi - lo)) * 32))) in f32, and 0 where hi == lo (rto's quantise).
fn quantise(c: f32, lo: f32, hi: f32) -> u32 {
  if (hi == lo) { return 0u; }
  let t = ((c - lo) / (hi - lo)) * 32.0;
  return min(31u, u32(floor(t)));
}

// Spreads the low 5 bits of v so that bit b lands on bit 3b (the oracle's 10-bit spread, masked to 5 bits).
fn spread3(v: u32) -> u32 {
  var x = v & 31u;
  x = (x | (x << 16u)) & 0x030000ffu;
  x = (x | (x << 8u)) & 0x0300f00fu;
  x = (x | (x << 4u)) & 0x030c30c3u;
  x = (x | (x << 2u)) & 0x09249249u;
  return x;
}

// x in the highest position of each triple (DESIGN.md §3).
fn morton15(q: vec3<u32>) -> u32 { return (spread3(q.x) << 2u) | (spread3(q.y) << 1u) | spread3(q.z); }

// One thread per slot of the sort buffer: a keyed instance's key in its own slot, the sentinel in every other (an
// instance of an empty BLAS, the padding up to `slots`), so the whole buffer is written and the keys sort to the
// front without a compaction pass.
@compute @workgroup_size(WG)
fn morton_keys(@builtin(global_invocation_id) gid: vec3<u32>) {
  let i = gid.x;
  if (i >= p.slots) { return; }
  if (i >= p.n || is_empty(boxes[i])) {
    keys[i] = SENTINEL;
    return;
  }
  let c = centroid(boxes[i]);
  let lo = bounds[0].xyz;
  let hi = bounds[1].xyz;
  let q = vec3(quantise(c.x, lo.x, hi.x), quantise(c.y, lo.y, hi.y), quantise(c.z, lo.z, hi.z));
  keys[i] = (morton15(q) << 16u) | i;
}

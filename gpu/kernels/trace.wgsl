// TRACE: ordered traversal of one ray over the packed scene, DESIGN.md §6 (src/trace/intersect.c and traverse.c are
// the reference; every expression below is theirs, in their order, and trace_keep stops the compiler from regrouping
// them, so llvmpipe gives the oracle's bits).
//
// Interface (include this file; it includes scene.wgsl, which binds the scene as @group(1) @binding(0)):
//   fn trace_ray(r: WfRay) -> TraceResult
//   struct TraceResult { hit: HitRecord, counters: TraceCounters, status: u32 }
// hit is the §6 record (the miss record on a miss), counters the §6 per-ray counters, status 0 or a set of
// TRACE_STATUS_* bits: REFUSED (a non-finite origin, direction, tMin or tMax, or tMin > tMax: not traced, the miss
// record and zero counters are returned, where the oracle refuses the whole batch) and STACK_OVERFLOW (the tree is
// deeper than TRACE_STACK_SIZE allows: traversal stopped, the record is not to be trusted). A harness turns a
// non-zero status into a failure.
//
// One stack serves both levels: a BLAS traversal runs to its end before the TLAS traversal resumes (§6), so its
// entries sit above the TLAS's. Ordered traversal pops one entry and pushes at most two, so a tree of depth D keeps
// at most D + 1 entries: a sweep TLAS (<= 65,536 instances, depth <= 16) or a Karras TLAS (u32 keys, depth <= 32)
// below a Karras BLAS (unique u64 keys, depth <= 64) fits in 33 + 65 entries.
// #include "scene.wgsl"

const TRACE_STACK_SIZE = 112u;      // lib/trace.js's TRACE_STACK_SIZE mirrors it
const TRACE_STATUS_REFUSED = 1u;
const TRACE_STATUS_STACK_OVERFLOW = 2u;

struct TraceResult { hit: HitRecord, counters: TraceCounters, status: u32 }

// Per-invocation traversal state (private: one copy per invocation).
var<private> trace_stack_ref: array<u32, TRACE_STACK_SIZE>;
var<private> trace_stack_t: array<f32, TRACE_STACK_SIZE>;
var<private> trace_top: u32;
var<private> trace_best_t: f32;
var<private> trace_found: bool;
var<private> trace_done: bool;    // TERMINATE_ON_FIRST_HIT and a hit, or an overflow: stop everything
var<private> trace_hit: HitRecord;
var<private> trace_counters: TraceCounters;
var<private> trace_status: u32;

// rto__minf / rto__maxf: `a < b ? a : b`, spelled out so that no min()/max() NaN convention can differ.
fn trace_min(a: f32, b: f32) -> f32 { return select(b, a, a < b); }
fn trace_max(a: f32, b: f32) -> f32 { return select(b, a, a > b); }

// WGSL has no isfinite(), and a compiler may assume away NaN in comparisons: test the exponent bits instead.
fn trace_finite(x: f32) -> bool { return (bitcast<u32>(x) & 0x7F800000u) != 0x7F800000u; }

fn trace_ray_refused(r: WfRay) -> bool {
  let finite = trace_finite(r.origin.x) && trace_finite(r.origin.y) && trace_finite(r.origin.z) &&
               trace_finite(r.dir.x) && trace_finite(r.dir.y) && trace_finite(r.dir.z) &&
               trace_finite(r.tMin) && trace_finite(r.tMax);
  return !finite || r.tMin > r.tMax;
}

// §2: a component below 1e-20 in magnitude becomes +-1e-20 (+1e-20 for +-0) before 1/d; slab tests only.
fn trace_inv_component(d: f32) -> f32 {
  var c = d;
  if (abs(c) < 1e-20) { c = select(1e-20, -1e-20, c < 0.0); }
  return 1.0 / c;
}
fn trace_inv_dir(d: vec3<f32>) -> vec3<f32> {
  return vec3<f32>(trace_inv_component(d.x), trace_inv_component(d.y), trace_inv_component(d.z));
}

// §6 slab test: whether the box is hit, and its entry t (tNear).
struct SlabHit { hit: bool, t: f32 }
fn trace_slab(bmin: vec3<f32>, bmax: vec3<f32>, o: vec3<f32>, inv: vec3<f32>, tMin: f32, bestT: f32) -> SlabHit {
  let t0 = vec3<f32>((bmin.x - o.x) * inv.x, (bmin.y - o.y) * inv.y, (bmin.z - o.z) * inv.z);
  let t1 = vec3<f32>((bmax.x - o.x) * inv.x, (bmax.y - o.y) * inv.y, (bmax.z - o.z) * inv.z);
  let lo = vec3<f32>(trace_min(t0.x, t1.x), trace_min(t0.y, t1.y), trace_min(t0.z, t1.z));
  let hi = vec3<f32>(trace_max(t0.x, t1.x), trace_max(t0.y, t1.y), trace_max(t0.z, t1.z));
  let tNear = trace_max(trace_max(trace_max(lo.x, lo.y), lo.z), tMin);
  let tFar = trace_min(trace_min(trace_min(hi.x, hi.y), hi.z), bestT);
  return SlabHit(tNear <= tFar, tNear);
}

// x, unchanged, through an operation the shader compiler cannot see through. Compilers may rewrite inexact float
// expressions (Mesa turns `a*c + b*c` into `(a + b)*c`, so llvmpipe's u + v is not the sum of the rounded u and v);
// a bitwise OR with a word the compiler cannot know (always 0) pins x down as the rounded value it is.
fn trace_keep(x: f32) -> f32 { return bitcast<f32>(bitcast<u32>(x) | scene[SCENE_ZERO]); }

// A product that stays a product: GPUs fuse `a*b + c` into one fused multiply-add (NVIDIA's compiler does), which
// skips the product's rounding. §6's expressions round every product, and rays aimed at edges and vertices (the
// grazing and axis sets) tell the difference: a fused edge test can let a ray through between two triangles.
fn trace_mul(a: f32, b: f32) -> f32 { return trace_keep(a * b); }

// §6 dot and cross, written out (no dot()/cross(): their evaluation order is the implementation's).
fn trace_dot(a: vec3<f32>, b: vec3<f32>) -> f32 {
  return (trace_mul(a.x, b.x) + trace_mul(a.y, b.y)) + trace_mul(a.z, b.z);
}
fn trace_cross(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
  return vec3<f32>(trace_mul(a.y, b.z) - trace_mul(a.z, b.y), trace_mul(a.z, b.x) - trace_mul(a.x, b.z),
                   trace_mul(a.x, b.y) - trace_mul(a.y, b.x));
}

// Möller–Trumbore in §6's order; ok = the hit test (culling comes after, from det).
struct TriHit { ok: bool, t: f32, u: f32, v: f32, det: f32 }
fn trace_triangle(tri: Triangle, o: vec3<f32>, d: vec3<f32>, tMin: f32, bestT: f32) -> TriHit {
  var h = TriHit(false, 0.0, 0.0, 0.0, 0.0);
  let e1 = vec3<f32>(tri.v1.x - tri.v0.x, tri.v1.y - tri.v0.y, tri.v1.z - tri.v0.z);
  let e2 = vec3<f32>(tri.v2.x - tri.v0.x, tri.v2.y - tri.v0.y, tri.v2.z - tri.v0.z);
  let p = trace_cross(d, e2);
  h.det = trace_dot(e1, p);
  if (h.det != 0.0) {
    let inv = 1.0 / h.det;
    let s = vec3<f32>(o.x - tri.v0.x, o.y - tri.v0.y, o.z - tri.v0.z);
    let q = trace_cross(s, e1);
    h.u = trace_dot(s, p) * inv;
    h.v = trace_dot(d, q) * inv;
    h.t = trace_dot(e2, q) * inv;
    // u and v share the factor inv: without trace_keep the sum is factored as (dot + dot) * inv.
    h.ok = h.u >= 0.0 && h.v >= 0.0 && trace_keep(h.u) + trace_keep(h.v) <= 1.0 && tMin <= h.t && h.t < bestT;
  }
  return h;
}

fn trace_culled(flags: u32, det: f32) -> bool {
  return ((flags & RAY_FLAG_CULL_BACK_FACING) != 0u && det < 0.0) ||
         ((flags & RAY_FLAG_CULL_FRONT_FACING) != 0u && det > 0.0);
}

// §6's miss record of a ray.
fn trace_miss_record(tMax: f32) -> HitRecord {
  return HitRecord(tMax, NO_ID, NO_ID, NO_ID, vec2<f32>(0.0, 0.0), NO_ID, 1u, mat4x3<f32>());
}

fn trace_push(nref: u32, t: f32) {
  if (trace_top >= TRACE_STACK_SIZE) {
    trace_status |= TRACE_STATUS_STACK_OVERFLOW;
    trace_done = true;
    return;
  }
  trace_stack_ref[trace_top] = nref;
  trace_stack_t[trace_top] = t;
  trace_top += 1u;
}

// Both children of a node in visiting order: the farther pushed first, the left first on equal entry t.
fn trace_push_pair(hl: SlabHit, l: u32, hr: SlabHit, r: u32) {
  if (hl.hit && hr.hit) {
    if (hl.t <= hr.t) {
      trace_push(r, hr.t);
      trace_push(l, hl.t);
    } else {
      trace_push(l, hl.t);
      trace_push(r, hr.t);
    }
  } else if (hl.hit) {
    trace_push(l, hl.t);
  } else if (hr.hit) {
    trace_push(r, hr.t);
  }
}

// Triangle prim of instance inst against the object-space ray; an accepted hit becomes the best so far.
fn trace_test_triangle(inst: u32, prim: u32, o: vec3<f32>, d: vec3<f32>, r: WfRay) {
  trace_counters.triangleTests += 1u;
  let h = trace_triangle(instance_triangle(inst, prim), o, d, r.tMin, trace_best_t);
  if (!h.ok || trace_culled(r.flags, h.det)) { return; }
  trace_best_t = h.t;
  trace_hit = HitRecord(h.t, inst, prim, instance_sbt_offset(inst), vec2<f32>(h.u, h.v), instance_custom_index(inst),
                        0u, instance_obj_to_world(inst));
  trace_found = true;
  if ((r.flags & RAY_FLAG_TERMINATE_ON_FIRST_HIT) != 0u) { trace_done = true; }
}

// Row r of W2O applied as ((m0·x + m1·y) + m2·z) + m3 (points) or without m3 (directions): not renormalised, so t
// is shared with the world ray.
fn trace_xform_point(m: vec4<f32>, p: vec3<f32>) -> f32 { return trace_xform_dir(m, p) + m.w; }
fn trace_xform_dir(m: vec4<f32>, d: vec3<f32>) -> f32 {
  return (trace_mul(m.x, d.x) + trace_mul(m.y, d.y)) + trace_mul(m.z, d.z);
}

// The BLAS of instance inst, entered: the whole tree in order before the TLAS resumes (entries above the TLAS's).
fn trace_blas(inst: u32, r: WfRay) {
  let m = instance_blas(inst);
  let w0 = instance_world_to_obj_row(inst, 0u);
  let w1 = instance_world_to_obj_row(inst, 1u);
  let w2 = instance_world_to_obj_row(inst, 2u);
  let o = vec3<f32>(trace_xform_point(w0, r.origin), trace_xform_point(w1, r.origin), trace_xform_point(w2, r.origin));
  let d = vec3<f32>(trace_xform_dir(w0, r.dir), trace_xform_dir(w1, r.dir), trace_xform_dir(w2, r.dir));
  // The §2 clamp feeds only the slab tests; Möller–Trumbore takes the unclamped object-space direction.
  let inv = trace_inv_dir(d);
  trace_counters.instanceEntries += 1u;
  let n = mesh_triangle_count(m);
  if (n == 0u) { return; }          // an empty mesh has no TLAS leaf, so this is never reached
  if (n == 1u) {                    // no internal node: straight to the triangle
    trace_test_triangle(inst, blas_order(m, 0u), o, d, r);
    return;
  }
  let base = trace_top;
  // The root is internal node 0, entered without a box test: its stored child boxes are the tests.
  trace_push(0u, r.tMin);
  while (trace_top > base && !trace_done) {
    trace_top -= 1u;
    let nref = trace_stack_ref[trace_top];
    if (trace_stack_t[trace_top] > trace_best_t) { continue; }
    trace_counters.nodesVisited += 1u;
    if ((nref & BVH_LEAF_BIT) != 0u) {
      trace_test_triangle(inst, blas_order(m, nref & ~BVH_LEAF_BIT), o, d, r);
      continue;
    }
    let node = blas_node(m, nref);
    trace_counters.boxTests += 2u;
    let hl = trace_slab(node.lmin, node.lmax, o, inv, r.tMin, trace_best_t);
    let hr = trace_slab(node.rmin, node.rmax, o, inv, r.tMin, trace_best_t);
    trace_push_pair(hl, node.left, hr, node.right);
  }
  trace_top = base;                 // TERMINATE_ON_FIRST_HIT leaves entries behind; the TLAS stops too
}

// A TLAS leaf reached: its instance is entered when its mask meets the ray's cull mask.
fn trace_visit_instance(inst: u32, r: WfRay) {
  if ((instance_mask(inst) & r.cullMask) != 0u) { trace_blas(inst, r); }
}

fn trace_sweep(r: WfRay, inv: vec3<f32>) {
  if (scene_tlas_node_count() == 0u) { return; }
  let firstLeaf = scene_tlas_first_leaf();
  // The root box is tested like any node; an EMPTY node is skipped by its item, never by a box test.
  let root = tlas_node(0u);
  if (root.item != TLAS_EMPTY) {
    trace_counters.boxTests += 1u;
    let h = trace_slab(root.bmin, root.bmax, r.origin, inv, r.tMin, trace_best_t);
    if (h.hit) { trace_push(0u, h.t); }
  }
  while (trace_top > 0u && !trace_done) {
    trace_top -= 1u;
    let nref = trace_stack_ref[trace_top];
    if (trace_stack_t[trace_top] > trace_best_t) { continue; }
    trace_counters.nodesVisited += 1u;
    if (nref >= firstLeaf) {
      trace_visit_instance(tlas_node_item(nref), r);
      continue;
    }
    let l = 2u * nref + 1u;
    let rr = 2u * nref + 2u;
    var hl = SlabHit(false, 0.0);
    var hr = SlabHit(false, 0.0);
    let nl = tlas_node(l);
    if (nl.item != TLAS_EMPTY) {
      trace_counters.boxTests += 1u;
      hl = trace_slab(nl.bmin, nl.bmax, r.origin, inv, r.tMin, trace_best_t);
    }
    let nr = tlas_node(rr);
    if (nr.item != TLAS_EMPTY) {
      trace_counters.boxTests += 1u;
      hr = trace_slab(nr.bmin, nr.bmax, r.origin, inv, r.tMin, trace_best_t);
    }
    trace_push_pair(hl, l, hr, rr);
  }
}

fn trace_karras_tlas(r: WfRay, inv: vec3<f32>) {
  let keys = scene_tlas_key_count();
  if (keys == 0u) { return; }
  if (keys == 1u) {                 // no internal node: straight to the one instance
    trace_visit_instance(tlas_leaf_instance(0u), r);
    return;
  }
  trace_push(0u, r.tMin);
  while (trace_top > 0u && !trace_done) {
    trace_top -= 1u;
    let nref = trace_stack_ref[trace_top];
    if (trace_stack_t[trace_top] > trace_best_t) { continue; }
    trace_counters.nodesVisited += 1u;
    if ((nref & BVH_LEAF_BIT) != 0u) {
      trace_visit_instance(tlas_leaf_instance(nref & ~BVH_LEAF_BIT), r);
      continue;
    }
    let node = tlas_karras_node(nref);
    trace_counters.boxTests += 2u;
    let hl = trace_slab(node.lmin, node.lmax, r.origin, inv, r.tMin, trace_best_t);
    let hr = trace_slab(node.rmin, node.rmax, r.origin, inv, r.tMin, trace_best_t);
    trace_push_pair(hl, node.left, hr, node.right);
  }
}

fn trace_ray(r: WfRay) -> TraceResult {
  trace_top = 0u;
  trace_best_t = r.tMax;
  trace_found = false;
  trace_done = false;
  trace_counters = TraceCounters(0u, 0u, 0u, 0u);
  trace_status = 0u;
  if (trace_ray_refused(r)) {
    return TraceResult(trace_miss_record(r.tMax), trace_counters, TRACE_STATUS_REFUSED);
  }
  let inv = trace_inv_dir(r.dir);
  if (scene_tlas_kind() == TLAS_KIND_KARRAS) {
    trace_karras_tlas(r, inv);
  } else {
    trace_sweep(r, inv);
  }
  var hit = trace_miss_record(r.tMax);
  if (trace_found) { hit = trace_hit; }
  return TraceResult(hit, trace_counters, trace_status);
}

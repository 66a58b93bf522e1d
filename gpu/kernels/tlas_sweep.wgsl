// The TLAS sweep tree of DESIGN.md §5 over the sorted TLAS keys (src/bvh/tlas.c): heap order over n_padded
// leaves, children of node i at 2i+1 and 2i+2, leaf j (sorted position j) at node n_padded - 1 + j. Two entry points:
//   leaves  one thread per leaf: the instance of a real key with its world box, EMPTY (+inf, -inf) for a sentinel
//   level   one thread per node of one level (one dispatch per level, deepest first): the union of its children
// Every word of every node is written, pad included, so no earlier case's bytes survive in the buffer.

const SENTINEL = 0xFFFFFFFFu;
const INTERNAL = 0xFFFFFFFFu;
const EMPTY = 0xFFFFFFFEu;

struct TlasNode { lo: vec3<f32>, item: u32, hi: vec3<f32>, pad: u32 }  // 32 bytes: min, item, max, pad
struct Aabb { lo: vec3<f32>, hi: vec3<f32> }

// leaves: first = n_padded - 1 (the first leaf's node), count = n_padded; level: the level's first node and width.
struct Params { first: u32, count: u32, pad0: u32, pad1: u32 }

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read_write> nodes: array<TlasNode>;
@group(0) @binding(2) var<storage, read> sorted: array<u32>;
@group(0) @binding(3) var<storage, read> boxes: array<Aabb>;

var<private> INF_BITS: u32 = 0x7f800000u;  // +inf at run time: a constant expression may not be infinite
fn inf() -> f32 { return bitcast<f32>(INF_BITS); }

// The oracle's min / max (rto__minf / rto__maxf): the second operand when both compare equal.
fn minf(a: f32, b: f32) -> f32 { return select(b, a, a < b); }
fn maxf(a: f32, b: f32) -> f32 { return select(b, a, a > b); }

@compute @workgroup_size(64)
fn leaves(@builtin(global_invocation_id) gid: vec3<u32>) {
  let j = gid.x;
  if (j >= p.count) { return; }
  let key = sorted[j];
  if (key == SENTINEL) {
    nodes[p.first + j] = TlasNode(vec3(inf()), EMPTY, vec3(-inf()), 0u);
    return;
  }
  let inst = key & 0xFFFFu;  // the instance index sits in the key's low 16 bits (§3)
  let b = boxes[inst];
  nodes[p.first + j] = TlasNode(b.lo, inst, b.hi, 0u);
}

@compute @workgroup_size(64)
fn level(@builtin(global_invocation_id) gid: vec3<u32>) {
  if (gid.x >= p.count) { return; }
  let i = p.first + gid.x;
  let l = nodes[2u * i + 1u];
  let r = nodes[2u * i + 2u];
  // EMPTY boxes are the union's identity, so no case for them; only the item says whether a real leaf is below.
  let lo = vec3(minf(l.lo.x, r.lo.x), minf(l.lo.y, r.lo.y), minf(l.lo.z, r.lo.z));
  let hi = vec3(maxf(l.hi.x, r.hi.x), maxf(l.hi.y, r.hi.y), maxf(l.hi.z, r.hi.z));
  let item = select(INTERNAL, EMPTY, l.item == EMPTY && r.item == EMPTY);
  nodes[i] = TlasNode(lo, item, hi, 0u);
}

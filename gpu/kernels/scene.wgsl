// The shared scene interface of the tracing kernels (DESIGN.md §5 layouts, §6 hit record, §7 WfRay).
//
// A kernel that traces includes this file (through trace.wgsl) and binds the packed scene as group 1, binding 0:
//   JS:   const scene = uploadScene(device, bundle);            // gpu/lib/scene.js
//         pass.setBindGroup(1, bind(device, pipe, 1, [scene.buffer]));
// so the whole scene costs one of the 8 storage buffers a compat-mode stage may have.
//
// The packed buffer is an array of u32 words (floats are their bit patterns; offsets count words):
//   header (SCENE_HEADER_WORDS)   see the SCENE_* indices below
//   mesh table                    MESH_WORDS per mesh: the counts and offsets of its BLAS and geometry
//   instances                     INSTANCE_WORDS per instance: the bundle's InstanceRecord (128 bytes) verbatim
//   TLAS nodes                    sweep: TlasNode (8 words); karras: BvhNode (16 words)
//   TLAS sorted keys              karras only: leaf j -> instance (key & 0xFFFF)
//   per mesh: BLAS nodes (BvhNode, 16 words), leaf order (1 word), positions (3 words), indices (3 words)
// gpu/lib/scene.js writes exactly this; docs/gpu.md "Scene buffer and TRACE" has the table.

// §7: one ray of a wavefront queue (64 bytes).
struct WfRay {
  origin: vec3<f32>, tMin: f32,
  dir: vec3<f32>, tMax: f32,
  pixel: u32, flags: u32, cullMask: u32, missIndex: u32,
  sbtOffset: u32, payloadSlot: u32, kind: u32, pad: u32,
}

// §6: the GPU's HitResult (96 bytes; WGSL alignment puts objToWorld at offset 32, columns padded to 16 bytes).
struct HitRecord {
  t: f32, instanceId: u32, primId: u32, hitGroup: u32,
  bary: vec2<f32>, customIndex: u32, missFlag: u32,
  objToWorld: mat4x3<f32>,
}

// §6: per-ray traversal counters (16 bytes).
struct TraceCounters { nodesVisited: u32, boxTests: u32, triangleTests: u32, instanceEntries: u32 }

// §5: a sweep TLAS node (the item tells a real leaf, INTERNAL or EMPTY apart).
struct TlasNode { bmin: vec3<f32>, item: u32, bmax: vec3<f32> }

// §5: a Karras node (BLAS, or a Karras TLAS): the two child boxes are stored in the parent.
struct BvhNode {
  lmin: vec3<f32>, left: u32,
  lmax: vec3<f32>, right: u32,
  rmin: vec3<f32>, parent: u32,
  rmax: vec3<f32>,
}

// A triangle's three vertices in its mesh's object space.
struct Triangle { v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32> }

@group(1) @binding(0) var<storage, read> scene: array<u32>;

// §5 constants and §6 ray flags.
const TLAS_INTERNAL = 0xFFFFFFFFu;
const TLAS_EMPTY = 0xFFFFFFFEu;
const BVH_LEAF_BIT = 0x80000000u;
const NO_ID = 0xFFFFFFFFu;
const RAY_FLAG_OPAQUE = 0x1u;
const RAY_FLAG_TERMINATE_ON_FIRST_HIT = 0x4u;
const RAY_FLAG_SKIP_CLOSEST_HIT = 0x8u;
const RAY_FLAG_CULL_BACK_FACING = 0x10u;
const RAY_FLAG_CULL_FRONT_FACING = 0x20u;

// Header word indices.
const SCENE_HEADER_WORDS = 16u;
const SCENE_VERSION = 0u;            // 1
const SCENE_INSTANCE_COUNT = 1u;
const SCENE_MESH_COUNT = 2u;
const SCENE_TLAS_KIND = 3u;          // TLAS_KIND_SWEEP or TLAS_KIND_KARRAS
const SCENE_TLAS_NODE_COUNT = 4u;
const SCENE_TLAS_FIRST_LEAF = 5u;    // sweep: N_PADDED - 1 (leaf j is node FIRST_LEAF + j); karras: 0
const SCENE_TLAS_KEY_COUNT = 6u;     // instances with a TLAS leaf (non-empty world box)
const SCENE_INSTANCES = 7u;          // offset of instance 0
const SCENE_TLAS_NODES = 8u;         // offset of TLAS node 0
const SCENE_TLAS_KEYS = 9u;          // offset of the sorted TLAS keys (karras; sweep: the same, unused)
const SCENE_MESH_TABLE = 10u;        // offset of mesh 0's table entry
const SCENE_TLAS_DEPTH = 11u;        // the TLAS depth (root = 0)
const SCENE_BLAS_DEPTH = 12u;        // the deepest BLAS's depth
const SCENE_HAS_GEOMETRY = 13u;      // 1 when positions and indices are there (a build bundle has none)
const SCENE_ZERO = 15u;              // always 0: a value the shader compiler cannot know (trace.wgsl's trace_keep)
const TLAS_KIND_SWEEP = 0u;
const TLAS_KIND_KARRAS = 1u;

// Mesh table entry word indices (MESH_WORDS per mesh).
const MESH_WORDS = 8u;
const MESH_TRIANGLE_COUNT = 0u;
const MESH_VERTEX_COUNT = 1u;
const MESH_BLAS_NODE_COUNT = 2u;     // triangles - 1 (0 for 0 or 1 triangle)
const MESH_BLAS_NODES = 3u;
const MESH_ORDER = 4u;               // leaf j -> triangle order[j]
const MESH_POSITIONS = 5u;           // f32 x, y, z per vertex
const MESH_INDICES = 6u;             // u32 i0, i1, i2 per triangle

// Instance record word indices (INSTANCE_WORDS per instance; row r of a 3x4 matrix = words 4r .. 4r + 3).
const INSTANCE_WORDS = 32u;
const INSTANCE_OBJ_TO_WORLD = 0u;
const INSTANCE_WORLD_TO_OBJ = 12u;
const INSTANCE_BLAS = 24u;
const INSTANCE_CUSTOM_INDEX = 25u;
const INSTANCE_MASK = 26u;
const INSTANCE_SBT_OFFSET = 27u;
const INSTANCE_FLAGS = 28u;

const TLAS_NODE_WORDS = 8u;
const BVH_NODE_WORDS = 16u;

fn scene_f32(w: u32) -> f32 { return bitcast<f32>(scene[w]); }
fn scene_vec3(w: u32) -> vec3<f32> { return vec3<f32>(scene_f32(w), scene_f32(w + 1u), scene_f32(w + 2u)); }
fn scene_vec4(w: u32) -> vec4<f32> {
  return vec4<f32>(scene_f32(w), scene_f32(w + 1u), scene_f32(w + 2u), scene_f32(w + 3u));
}

fn scene_header(i: u32) -> u32 { return scene[i]; }
fn scene_instance_count() -> u32 { return scene[SCENE_INSTANCE_COUNT]; }
fn scene_mesh_count() -> u32 { return scene[SCENE_MESH_COUNT]; }
fn scene_tlas_kind() -> u32 { return scene[SCENE_TLAS_KIND]; }
fn scene_tlas_node_count() -> u32 { return scene[SCENE_TLAS_NODE_COUNT]; }
fn scene_tlas_first_leaf() -> u32 { return scene[SCENE_TLAS_FIRST_LEAF]; }
fn scene_tlas_key_count() -> u32 { return scene[SCENE_TLAS_KEY_COUNT]; }

// ---- instances ----
fn instance_word(i: u32, field: u32) -> u32 { return scene[scene[SCENE_INSTANCES] + i * INSTANCE_WORDS + field]; }
// Row r (0..2) of the row-major 3x4 objToWorld: (m_r0, m_r1, m_r2, m_r3), m_r3 the translation.
fn instance_obj_to_world_row(i: u32, r: u32) -> vec4<f32> {
  return scene_vec4(scene[SCENE_INSTANCES] + i * INSTANCE_WORDS + INSTANCE_OBJ_TO_WORLD + 4u * r);
}
fn instance_world_to_obj_row(i: u32, r: u32) -> vec4<f32> {
  return scene_vec4(scene[SCENE_INSTANCES] + i * INSTANCE_WORDS + INSTANCE_WORLD_TO_OBJ + 4u * r);
}
fn instance_blas(i: u32) -> u32 { return instance_word(i, INSTANCE_BLAS); }
fn instance_custom_index(i: u32) -> u32 { return instance_word(i, INSTANCE_CUSTOM_INDEX); }
fn instance_mask(i: u32) -> u32 { return instance_word(i, INSTANCE_MASK); }
fn instance_sbt_offset(i: u32) -> u32 { return instance_word(i, INSTANCE_SBT_OFFSET); }
fn instance_flags(i: u32) -> u32 { return instance_word(i, INSTANCE_FLAGS); }
// objToWorld as the hit record holds it: WGSL's column-major mat4x3, column c = row-major elements [0..2][c].
fn instance_obj_to_world(i: u32) -> mat4x3<f32> {
  let r0 = instance_obj_to_world_row(i, 0u);
  let r1 = instance_obj_to_world_row(i, 1u);
  let r2 = instance_obj_to_world_row(i, 2u);
  return mat4x3<f32>(vec3<f32>(r0.x, r1.x, r2.x), vec3<f32>(r0.y, r1.y, r2.y), vec3<f32>(r0.z, r1.z, r2.z),
                     vec3<f32>(r0.w, r1.w, r2.w));
}

// ---- TLAS ----
// Sweep layout: node n of the heap (children 2n + 1, 2n + 2).
fn tlas_node(n: u32) -> TlasNode {
  let w = scene[SCENE_TLAS_NODES] + n * TLAS_NODE_WORDS;
  return TlasNode(scene_vec3(w), scene[w + 3u], scene_vec3(w + 4u));
}
fn tlas_node_item(n: u32) -> u32 { return scene[scene[SCENE_TLAS_NODES] + n * TLAS_NODE_WORDS + 3u]; }

fn bvh_node_at(w: u32) -> BvhNode {
  return BvhNode(scene_vec3(w), scene[w + 3u], scene_vec3(w + 4u), scene[w + 7u],
                 scene_vec3(w + 8u), scene[w + 11u], scene_vec3(w + 12u));
}
// Karras layout (--tlas karras): internal node n; leaf j is instance tlas_leaf_instance(j).
fn tlas_karras_node(n: u32) -> BvhNode { return bvh_node_at(scene[SCENE_TLAS_NODES] + n * BVH_NODE_WORDS); }
fn tlas_leaf_instance(j: u32) -> u32 { return scene[scene[SCENE_TLAS_KEYS] + j] & 0xFFFFu; }

// ---- meshes and their BLAS (mesh index = instance_blas) ----
fn mesh_word(m: u32, field: u32) -> u32 { return scene[scene[SCENE_MESH_TABLE] + m * MESH_WORDS + field]; }
fn mesh_triangle_count(m: u32) -> u32 { return mesh_word(m, MESH_TRIANGLE_COUNT); }
fn mesh_vertex_count(m: u32) -> u32 { return mesh_word(m, MESH_VERTEX_COUNT); }
fn blas_node_count(m: u32) -> u32 { return mesh_word(m, MESH_BLAS_NODE_COUNT); }
fn blas_node(m: u32, n: u32) -> BvhNode { return bvh_node_at(mesh_word(m, MESH_BLAS_NODES) + n * BVH_NODE_WORDS); }
// The triangle of BLAS leaf j (the sorted key's low word).
fn blas_order(m: u32, j: u32) -> u32 { return scene[mesh_word(m, MESH_ORDER) + j]; }
// The three vertex indices of triangle prim.
fn mesh_triangle_indices(m: u32, prim: u32) -> vec3<u32> {
  let w = mesh_word(m, MESH_INDICES) + 3u * prim;
  return vec3<u32>(scene[w], scene[w + 1u], scene[w + 2u]);
}
fn mesh_position(m: u32, v: u32) -> vec3<f32> { return scene_vec3(mesh_word(m, MESH_POSITIONS) + 3u * v); }
fn mesh_triangle(m: u32, prim: u32) -> Triangle {
  let ix = mesh_triangle_indices(m, prim);
  return Triangle(mesh_position(m, ix.x), mesh_position(m, ix.y), mesh_position(m, ix.z));
}
// Triangle primId of instance inst, in object space.
fn instance_triangle(inst: u32, prim: u32) -> Triangle { return mesh_triangle(instance_blas(inst), prim); }

// The visibility pass of seed 004 (DESIGN.md §11.1, §11.4): a render pipeline drawing a scene's instanced triangles
// non-indexed with vertex pulling (triangle = vertex_index / 3, corner = vertex_index % 3), one draw per instance
// (its index arrives as instance_index through the draw's firstInstance), into four colour targets and depth24plus:
//   0 rgba16uint   primitive index (lo, hi 16 bits), instance index (lo, hi)
//   1 rg16float    (b1, b2): corner outputs (0, 0), (1, 0), (0, 1) interpolated (perspective, center)
//   2 rgba16float  octahedral world face normal (flat: computed per vertex from the three world positions), 0, 1
//   3 rgba16float  dpdxFine (b1, b2), dpdyFine (b1, b2)
// group 0: camera (vb_camera.npy's 144 bytes), the bundle's InstanceRecords as words, the geometry words: a table of
// MESH_WORDS per mesh (triangles, positions at, indices at, pad) then every mesh's positions and indices.

struct Camera {
  view_proj: mat4x4<f32>,          // column-major: clip = view_proj · (world, 1)
  inverse_projection: mat4x4<f32>,
  position: vec4<f32>,
}

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<storage, read> instances: array<u32>;
@group(0) @binding(2) var<storage, read> geometry: array<u32>;

const INSTANCE_WORDS = 32u;
const INSTANCE_BLAS = 24u;
const MESH_WORDS = 4u;

struct Varyings {
  @builtin(position) clip: vec4<f32>,
  @location(0) bary: vec2<f32>,
  @location(1) @interpolate(flat, either) ids: vec4<u32>,
  @location(2) @interpolate(flat, either) oct: vec2<f32>,
}

struct Planes {
  @location(0) visibility: vec4<u32>,
  @location(1) barycentric: vec2<f32>,
  @location(2) normal: vec4<f32>,
  @location(3) derivatives: vec4<f32>,
}

fn word_f32(w: u32) -> f32 { return bitcast<f32>(geometry[w]); }

fn mesh_position(m: u32, v: u32) -> vec3<f32> {
  let w = geometry[m * MESH_WORDS + 1u] + 3u * v;
  return vec3<f32>(word_f32(w), word_f32(w + 1u), word_f32(w + 2u));
}

// world = objToWorld · p, row r = ((m_r0 x + m_r1 y) + m_r2 z) + m_r3 (§5's order; the InstanceRecord's row-major 3x4).
fn to_world(inst: u32, p: vec3<f32>) -> vec3<f32> {
  var w: vec3<f32>;
  for (var r = 0u; r < 3u; r++) {
    let at = inst * INSTANCE_WORDS + 4u * r;
    let m = vec4<f32>(bitcast<f32>(instances[at]), bitcast<f32>(instances[at + 1u]), bitcast<f32>(instances[at + 2u]),
                      bitcast<f32>(instances[at + 3u]));
    w[r] = ((m.x * p.x + m.y * p.y) + m.z * p.z) + m.w;
  }
  return w;
}

fn sign_not_zero(v: vec2<f32>) -> vec2<f32> {
  return select(vec2<f32>(-1.0), vec2<f32>(1.0), v >= vec2<f32>(0.0));
}

// Cigolle et al. 2014: p = n.xy / (|x| + |y| + |z|); below the equator p = (1 - |p.yx|) · signNotZero(p).
fn oct_encode(n: vec3<f32>) -> vec2<f32> {
  let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
  if (n.z < 0.0) { return (vec2<f32>(1.0) - abs(p.yx)) * sign_not_zero(p); }
  return p;
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) inst: u32) -> Varyings {
  let m = instances[inst * INSTANCE_WORDS + INSTANCE_BLAS];
  let prim = vi / 3u;
  let corner = vi % 3u;
  let at = geometry[m * MESH_WORDS + 2u] + 3u * prim;
  let w0 = to_world(inst, mesh_position(m, geometry[at]));
  let w1 = to_world(inst, mesh_position(m, geometry[at + 1u]));
  let w2 = to_world(inst, mesh_position(m, geometry[at + 2u]));
  let w = select(select(w0, w1, corner == 1u), w2, corner == 2u);
  let vp = camera.view_proj;
  var out: Varyings;
  out.clip = ((vp[0] * w.x + vp[1] * w.y) + vp[2] * w.z) + vp[3];
  out.bary = vec2<f32>(select(0.0, 1.0, corner == 1u), select(0.0, 1.0, corner == 2u));
  out.ids = vec4<u32>(prim & 0xFFFFu, prim >> 16u, inst & 0xFFFFu, inst >> 16u);
  out.oct = oct_encode(normalize(cross(w1 - w0, w2 - w0)));
  return out;
}

fn planes(v: Varyings, ddx: vec2<f32>, ddy: vec2<f32>) -> Planes {
  var out: Planes;
  out.visibility = v.ids;
  out.barycentric = v.bary;
  out.normal = vec4<f32>(v.oct, 0.0, 1.0);
  out.derivatives = vec4<f32>(ddx, ddy);
  return out;
}

// §11.4's derivatives are dpdxFine / dpdyFine (a core device).
@fragment
fn fs_main(v: Varyings) -> Planes { return planes(v, dpdxFine(v.bary), dpdyFine(v.bary)); }

// Compatibility mode forbids the fine derivative built-ins: dpdx / dpdy, fine or coarse as the device chooses (fine on
// llvmpipe, whose ddx differences each row of the 2x2 quad and ddy each column).
@fragment
fn fs_compat(v: Varyings) -> Planes { return planes(v, dpdx(v.bary), dpdy(v.bary)); }

// Compatibility mode multisamples no integer format and no rgba16float (of the G-buffer's, only rg16float): at 4x
// the planes are split over 7 targets it does multisample. The visibility words go byte by byte into two rgba8unorm
// targets (byte k written as k / 255, exact both ways; the clear value 1.0 is 0xFF), the four-channel planes into two
// rg16float targets each.
struct SplitPlanes {
  @location(0) prim: vec4<f32>,
  @location(1) instance: vec4<f32>,
  @location(2) barycentric: vec2<f32>,
  @location(3) normal_xy: vec2<f32>,
  @location(4) normal_zw: vec2<f32>,
  @location(5) ddx: vec2<f32>,
  @location(6) ddy: vec2<f32>,
}

fn unorm_bytes(w: u32) -> vec4<f32> {
  return vec4<f32>(f32(w & 0xFFu), f32((w >> 8u) & 0xFFu), f32((w >> 16u) & 0xFFu), f32(w >> 24u)) / 255.0;
}

@fragment
fn fs_split(v: Varyings) -> SplitPlanes {
  let p = planes(v, dpdx(v.bary), dpdy(v.bary));
  var out: SplitPlanes;
  out.prim = unorm_bytes(p.visibility.x | (p.visibility.y << 16u));
  out.instance = unorm_bytes(p.visibility.z | (p.visibility.w << 16u));
  out.barycentric = p.barycentric;
  out.normal_xy = p.normal.xy;
  out.normal_zw = p.normal.zw;
  out.ddx = p.derivatives.xy;
  out.ddy = p.derivatives.zw;
  return out;
}

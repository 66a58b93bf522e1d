// The material pass of seed 004 (DESIGN.md §11.5) on the visibility pass's planes (vb_dump.wgsl's word layout, N =
// width · height · samples): the classifier marks edge pixels (mask 1), interior pixels shade once from sample 0,
// edge pixels once per sample and average (a background sample shades to the clear colour 0). Materials: 0 normals
// (n · 0.5 + 0.5, alpha 1), 1 lambert (base colour · (ambient + (1 - ambient) max(0, n·L)), the base colour's alpha;
// the base colour is the instance's mesh's, vb_base_colors.npy), 2 unlit (the base colour factor times the mesh's
// texture, if it samples one: uv and its screen derivatives from the barycentrics, their derivatives and the mesh's
// UVs, lod = log2(max(|dUV/dx ⊙ size|, |dUV/dy ⊙ size|)) clamped to the levels, textureSampleLevel with a trilinear,
// repeat sampler; the levels are the bundle's vb_texture_T.npy, DESIGN.md §11.5). The image is RGBA16float as two
// pack2x16float words per pixel, the mask one u32 per pixel. One invocation per pixel.

struct Params {
  inverse_projection: mat4x4<f32>,
  sun: vec4<f32>,        // xyz: direction towards the light (normalised here), w: ambient
  thresholds: vec4<f32>, // normal, depth, sample depth, unused
  size: vec4<u32>,       // width, height, samples, N
  material: vec4<u32>,   // x: 0 normals, 1 lambert, 2 unlit
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> planes: array<u32>;
@group(0) @binding(2) var<storage, read_write> image: array<u32>;
@group(0) @binding(3) var<storage, read_write> mask: array<u32>;
@group(0) @binding(4) var<storage, read> instance_records: array<u32>; // InstanceRecords as words
@group(0) @binding(5) var<storage, read> base_colors: array<vec4<f32>>; // one per mesh
// unlit: per mesh 4 words (texture slot or NONE, where its UVs start, where its indices start, 0), then those words
@group(0) @binding(6) var<storage, read> tex_meshes: array<u32>;
@group(0) @binding(7) var tex0: texture_2d<f32>;
@group(0) @binding(8) var tex1: texture_2d<f32>;
@group(0) @binding(9) var tex2: texture_2d<f32>;
@group(0) @binding(10) var tex3: texture_2d<f32>;
@group(0) @binding(11) var tex_sampler: sampler; // linear, linear, mipmap linear, repeat

const INSTANCE_WORDS = 32u;
const INSTANCE_BLAS = 24u;

const BACKGROUND = 0xFFFFFFFFu;

fn instance_of(k: u32) -> u32 { return planes[2u * k + 1u]; }
// Covered: the triangle ID is not background (the seed's sampleCovered; material.c reads the same words).
fn covered(k: u32) -> bool { return planes[2u * k] != BACKGROUND; }
fn depth_of(k: u32) -> f32 { return bitcast<f32>(planes[7u * params.size.w + k]); }

// View depth at the pixel centre: (P⁻¹ · (ndc_x, ndc_y, d, 1)).z / .w.
fn view_depth(x: u32, y: u32, d: f32) -> f32 {
  let ndc = vec4<f32>((f32(x) + 0.5) / f32(params.size.x) * 2.0 - 1.0,
                      1.0 - (f32(y) + 0.5) / f32(params.size.y) * 2.0, d, 1.0);
  let v = params.inverse_projection * ndc;
  return v.z / v.w;
}

fn sign_not_zero(v: vec2<f32>) -> vec2<f32> {
  return select(vec2<f32>(-1.0), vec2<f32>(1.0), v >= vec2<f32>(0.0));
}

// The inverse of the visibility pass's octahedral encoding, normalised.
fn normal_of(k: u32) -> vec3<f32> {
  let e = unpack2x16float(planes[3u * params.size.w + 2u * k]);
  var n = vec3<f32>(e, 1.0 - abs(e.x) - abs(e.y));
  if (n.z < 0.0) { n = vec3<f32>((vec2<f32>(1.0) - abs(n.yx)) * sign_not_zero(n.xy), n.z); }
  return normalize(n);
}

fn texture_size(t: u32) -> vec3<u32> { // width, height, levels
  switch t {
    case 0u: { return vec3<u32>(textureDimensions(tex0), textureNumLevels(tex0)); }
    case 1u: { return vec3<u32>(textureDimensions(tex1), textureNumLevels(tex1)); }
    case 2u: { return vec3<u32>(textureDimensions(tex2), textureNumLevels(tex2)); }
    default: { return vec3<u32>(textureDimensions(tex3), textureNumLevels(tex3)); }
  }
}

// Trilinear at the isotropic level of detail of the footprint (dUV/dx, dUV/dy).
fn sample_texture(t: u32, uv: vec2<f32>, dx: vec2<f32>, dy: vec2<f32>) -> vec4<f32> {
  let sz = texture_size(t);
  let size = vec2<f32>(sz.xy);
  let rho = max(length(dx * size), length(dy * size));
  var lod = 0.0;
  if (rho > 0.0) { lod = clamp(log2(rho), 0.0, f32(sz.z - 1u)); }
  switch t {
    case 0u: { return textureSampleLevel(tex0, tex_sampler, uv, lod); }
    case 1u: { return textureSampleLevel(tex1, tex_sampler, uv, lod); }
    case 2u: { return textureSampleLevel(tex2, tex_sampler, uv, lod); }
    default: { return textureSampleLevel(tex3, tex_sampler, uv, lod); }
  }
}

fn mesh_uv(at: u32, v: u32) -> vec2<f32> {
  return vec2<f32>(bitcast<f32>(tex_meshes[at + 2u * v]), bitcast<f32>(tex_meshes[at + 2u * v + 1u]));
}

// unlit: uv = b0·uv0 + b1·uv1 + b2·uv2, dUV/dx = ddx(b1)·(uv1 − uv0) + ddx(b2)·(uv2 − uv0), likewise y.
fn unlit(k: u32, mesh: u32, base: vec4<f32>) -> vec4<f32> {
  let t = tex_meshes[4u * mesh];
  if (t == BACKGROUND) { return base; }
  let uv_at = tex_meshes[4u * mesh + 1u];
  let idx_at = tex_meshes[4u * mesh + 2u] + 3u * planes[2u * k];
  let uv0 = mesh_uv(uv_at, tex_meshes[idx_at]);
  let uv1 = mesh_uv(uv_at, tex_meshes[idx_at + 1u]);
  let uv2 = mesh_uv(uv_at, tex_meshes[idx_at + 2u]);
  let n = params.size.w;
  let b = unpack2x16float(planes[2u * n + k]);
  let b0 = 1.0 - b.x - b.y;
  let uv = (b0 * uv0 + b.x * uv1) + b.y * uv2;
  let ddx = unpack2x16float(planes[5u * n + 2u * k]);
  let ddy = unpack2x16float(planes[5u * n + 2u * k + 1u]);
  let e1 = uv1 - uv0;
  let e2 = uv2 - uv0;
  return base * sample_texture(t, uv, ddx.x * e1 + ddx.y * e2, ddy.x * e1 + ddy.y * e2);
}

fn shade(k: u32) -> vec4<f32> {
  if (!covered(k)) { return vec4<f32>(0.0); }
  let n = normal_of(k);
  if (params.material.x == 1u) {
    let ambient = params.sun.w;
    let light = ambient + (1.0 - ambient) * max(0.0, dot(n, normalize(params.sun.xyz)));
    let base = base_colors[instance_records[instance_of(k) * INSTANCE_WORDS + INSTANCE_BLAS]];
    return vec4<f32>(base.rgb * light, base.a);
  }
  if (params.material.x == 2u) {
    let mesh = instance_records[instance_of(k) * INSTANCE_WORDS + INSTANCE_BLAS];
    return unlit(k, mesh, base_colors[mesh]);
  }
  return vec4<f32>(n * 0.5 + 0.5, 1.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
  let w = params.size.x;
  let h = params.size.y;
  let samples = params.size.z;
  if (id.x >= w || id.y >= h) { return; }
  let pixel = id.y * w + id.x;
  let base = pixel * samples;
  let t_normal = params.thresholds.x;
  let t_depth = params.thresholds.y;
  let t_sample = params.thresholds.z;

  // Over the pixel's samples: how many are covered, their view-depth range, whether they span several instances.
  var count = 0u;
  var vmin = 0.0;
  var vmax = 0.0;
  var first = BACKGROUND;
  var instances = false;
  for (var s = 0u; s < samples; s++) {
    if (!covered(base + s)) { continue; }
    let vd = view_depth(id.x, id.y, depth_of(base + s));
    if (count == 0u) {
      vmin = vd;
      vmax = vd;
      first = instance_of(base + s);
    } else {
      vmin = min(vmin, vd);
      vmax = max(vmax, vd);
      instances = instances || instance_of(base + s) != first;
    }
    count++;
  }
  let c0 = covered(base);
  var edge = (!c0 && count > 0u) || instances || (count >= 2u && vmax - vmin > t_sample * abs(0.5 * (vmin + vmax)));
  if (c0) {
    let vd0 = view_depth(id.x, id.y, depth_of(base));
    let n0 = normal_of(base);
    let offsets = array<vec2<i32>, 4>(vec2<i32>(-1, 0), vec2<i32>(1, 0), vec2<i32>(0, -1), vec2<i32>(0, 1));
    for (var i = 0u; i < 4u; i++) {
      let q = vec2<i32>(id.xy) + offsets[i];
      if (q.x < 0 || q.y < 0 || q.x >= i32(w) || q.y >= i32(h)) { continue; }
      let kb = (u32(q.y) * w + u32(q.x)) * samples;
      if (!covered(kb) || dot(n0, normal_of(kb)) < t_normal ||
          abs(vd0 - view_depth(u32(q.x), u32(q.y), depth_of(kb))) > t_depth * abs(vd0)) {
        edge = true;
      }
    }
  }

  var color = shade(base);
  if (edge) {
    var sum = vec4<f32>(0.0);
    for (var s = 0u; s < samples; s++) { sum += shade(base + s); }
    color = sum / f32(samples);
  }
  image[2u * pixel] = pack2x16float(color.xy);
  image[2u * pixel + 1u] = pack2x16float(color.zw);
  mask[pixel] = select(0u, 1u, edge);
}

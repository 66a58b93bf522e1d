// The visibility pass's planes copied into one storage buffer of words (a multisampled texture cannot be copied to a
// buffer): every sample through textureLoad(texture, pixel, sample). Depth is bound as an unfilterable-float texture
// (its .x is the depth): compatibility mode forbids textureLoad of the texture_depth_* types. Entry points (each binds
// only the textures it uses, by an explicit layout): main_ms the multisampled G-buffer, main_1x the single-sampled one,
// main_split the 7 multisampled targets of vb_visibility.wgsl's fs_split (compatibility mode at 4x). Sample k =
// (y · width + x) · samples + s of N = width · height · samples; the word regions, as the .npy files hold them:
//   [0, 2N)   visibility  u16 x 4: (prim lo | prim hi << 16), (instance lo | instance hi << 16)
//   [2N, 3N)  barycentric f16 x 2: pack2x16float(b1, b2) (the target's binary16 values, exactly)
//   [3N, 5N)  normal      f16 x 4
//   [5N, 7N)  derivatives f16 x 4
//   [7N, 8N)  depth       f32

struct Params { width: u32, height: u32, samples: u32, n: u32 }

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var vis_ms: texture_multisampled_2d<u32>;
@group(0) @binding(3) var bary_ms: texture_multisampled_2d<f32>;
@group(0) @binding(4) var normal_ms: texture_multisampled_2d<f32>;
@group(0) @binding(5) var deriv_ms: texture_multisampled_2d<f32>;
@group(0) @binding(6) var depth_ms: texture_multisampled_2d<f32>;
@group(0) @binding(7) var vis_1x: texture_2d<u32>;
@group(0) @binding(8) var bary_1x: texture_2d<f32>;
@group(0) @binding(9) var normal_1x: texture_2d<f32>;
@group(0) @binding(10) var deriv_1x: texture_2d<f32>;
@group(0) @binding(11) var depth_1x: texture_2d<f32>;
@group(0) @binding(12) var prim_split: texture_multisampled_2d<f32>;
@group(0) @binding(13) var instance_split: texture_multisampled_2d<f32>;
@group(0) @binding(14) var bary_split: texture_multisampled_2d<f32>;
@group(0) @binding(15) var normal_xy_split: texture_multisampled_2d<f32>;
@group(0) @binding(16) var normal_zw_split: texture_multisampled_2d<f32>;
@group(0) @binding(17) var ddx_split: texture_multisampled_2d<f32>;
@group(0) @binding(18) var ddy_split: texture_multisampled_2d<f32>;
@group(0) @binding(19) var depth_split: texture_multisampled_2d<f32>;

fn store(k: u32, vis: vec4<u32>, bary: vec4<f32>, normal: vec4<f32>, deriv: vec4<f32>, depth: f32) {
  let n = params.n;
  out[2u * k] = (vis.x & 0xFFFFu) | (vis.y << 16u);
  out[2u * k + 1u] = (vis.z & 0xFFFFu) | (vis.w << 16u);
  out[2u * n + k] = pack2x16float(bary.xy);
  out[3u * n + 2u * k] = pack2x16float(normal.xy);
  out[3u * n + 2u * k + 1u] = pack2x16float(normal.zw);
  out[5u * n + 2u * k] = pack2x16float(deriv.xy);
  out[5u * n + 2u * k + 1u] = pack2x16float(deriv.zw);
  out[7u * n + k] = bitcast<u32>(depth);
}

@compute @workgroup_size(8, 8)
fn main_ms(@builtin(global_invocation_id) id: vec3<u32>) {
  if (id.x >= params.width || id.y >= params.height) { return; }
  let p = vec2<i32>(id.xy);
  for (var s = 0u; s < params.samples; s++) {
    let k = (id.y * params.width + id.x) * params.samples + s;
    let si = i32(s);
    store(k, textureLoad(vis_ms, p, si), textureLoad(bary_ms, p, si), textureLoad(normal_ms, p, si),
          textureLoad(deriv_ms, p, si), textureLoad(depth_ms, p, si).x);
  }
}

@compute @workgroup_size(8, 8)
fn main_1x(@builtin(global_invocation_id) id: vec3<u32>) {
  if (id.x >= params.width || id.y >= params.height) { return; }
  let p = vec2<i32>(id.xy);
  store(id.y * params.width + id.x, textureLoad(vis_1x, p, 0), textureLoad(bary_1x, p, 0),
        textureLoad(normal_1x, p, 0), textureLoad(deriv_1x, p, 0), textureLoad(depth_1x, p, 0).x);
}

// A word from the four unorm8 bytes fs_split wrote.
fn unorm_word(v: vec4<f32>) -> u32 {
  let b = vec4<u32>(round(v * 255.0));
  return b.x | (b.y << 8u) | (b.z << 16u) | (b.w << 24u);
}

@compute @workgroup_size(8, 8)
fn main_split(@builtin(global_invocation_id) id: vec3<u32>) {
  if (id.x >= params.width || id.y >= params.height) { return; }
  let p = vec2<i32>(id.xy);
  for (var s = 0u; s < params.samples; s++) {
    let k = (id.y * params.width + id.x) * params.samples + s;
    let si = i32(s);
    let prim = unorm_word(textureLoad(prim_split, p, si));
    let instance = unorm_word(textureLoad(instance_split, p, si));
    store(k, vec4<u32>(prim & 0xFFFFu, prim >> 16u, instance & 0xFFFFu, instance >> 16u),
          textureLoad(bary_split, p, si),
          vec4<f32>(textureLoad(normal_xy_split, p, si).xy, textureLoad(normal_zw_split, p, si).xy),
          vec4<f32>(textureLoad(ddx_split, p, si).xy, textureLoad(ddy_split, p, si).xy),
          textureLoad(depth_split, p, si).x);
  }
}

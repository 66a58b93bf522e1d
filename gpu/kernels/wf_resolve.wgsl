// RESOLVE (DESIGN.md §7): one invocation per pixel maps accum to the 8-bit image: the program's resolve (sun-shadow:
// Reinhard c / (1 + c), then pow(., 1 / 2.2), alpha 1; triangle: none, accum passes through), then per channel
// clamp to [0, 1] and round x 255 half up, NaN -> 0. Pixel row 0 is the top row; one u32 = RGBA bytes.
// #include "wf_common.wgsl"

@group(0) @binding(2) var<storage, read> accum: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> image: array<u32>;

fn sun_resolve(hdr: vec4<f32>) -> vec4<f32> {
  let mapped = vec3<f32>(hdr.x / (1.0 + hdr.x), hdr.y / (1.0 + hdr.y), hdr.z / (1.0 + hdr.z));
  return vec4<f32>(pow(mapped, vec3<f32>(1.0f / 2.2f)), 1.0);
}

// floor(x 255 + 0.5) on [0, 1]; NaN is tested on the bits, as a compiler may assume a comparison never sees NaN.
fn unorm8(x: f32) -> u32 {
  if ((bitcast<u32>(x) & 0x7FFFFFFFu) > 0x7F800000u || !(x > 0.0)) {
    return 0u;
  }
  if (x >= 1.0) {
    return 255u;
  }
  return u32(floor(x * 255.0 + 0.5));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
  if (gid.x >= frame.width || gid.y >= frame.height) {
    return;
  }
  let p = gid.y * frame.width + gid.x;
  var c = accum[p];
  if (PROGRAM == WF_PROGRAM_SUN_SHADOW) {
    c = sun_resolve(c);
  }
  image[p] = unorm8(c.x) | (unorm8(c.y) << 8u) | (unorm8(c.z) << 16u) | (unorm8(c.w) << 24u);
}

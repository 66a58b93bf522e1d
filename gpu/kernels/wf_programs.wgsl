// The built-in programs of DESIGN.md §7 (the oracle's src/frame/programs.c, operation by operation), selected by the
// PROGRAM define: closest hit and miss, run by SHADE. Their raygen (the camera ray) is in wf_generate.wgsl, their
// resolve in wf_resolve.wgsl. frame.params holds the parameters in the manifest's order.

// triangle (VulkanTriangle): params [miss]. Colour = barycentrics ((1 - u) - v, u, v), a dark blue miss.
fn triangle_hit(ray: WfRay, hit: HitRecord) {
  wf_accumulate(ray.pixel, vec3<f32>((1.0 - hit.bary.x) - hit.bary.y, hit.bary.x, hit.bary.y));
}

fn triangle_miss(ray: WfRay) {
  wf_accumulate(ray.pixel, frame.params[0].xyz);
}

// sun-shadow (Sponza): params [sun_dir, sun_color, ambient, sky]; payload = the shadow ray's throughput (3 floats).
const SUN_DIR = 0u;
const SUN_COLOR = 1u;
const SUN_AMBIENT = 2u;
const SUN_SKY = 3u;

// albedo x ambient, then, if N.L > 0, a shadow ray towards the sun carrying (albedo x sun) x N.L.
fn sun_hit(ray: WfRay, hit: HitRecord) {
  let s = wf_surface(ray, hit);
  var n = s.normal;
  if (wf_dot3(n, ray.dir) > 0.0) { // face the viewer: surfaces are seen from both sides
    n = -n;
  }
  let albedo = s.baseColor.xyz;
  wf_accumulate(ray.pixel, albedo * frame.params[SUN_AMBIENT].xyz);
  let l = wf_normalize(frame.params[SUN_DIR].xyz);
  let ndotl = wf_dot3(n, l);
  if (!(ndotl > 0.0)) {
    return;
  }
  let throughput = (albedo * frame.params[SUN_COLOR].xyz) * ndotl;
  var p: Payload;
  p[0] = bitcast<u32>(throughput.x);
  p[1] = bitcast<u32>(throughput.y);
  p[2] = bitcast<u32>(throughput.z);
  var shadow: WfRay;
  shadow.origin = s.position;
  shadow.tMin = frame.rayOffset;
  shadow.dir = l;
  shadow.tMax = WF_T_MAX;
  shadow.flags = RAY_FLAG_OPAQUE | RAY_FLAG_TERMINATE_ON_FIRST_HIT | RAY_FLAG_SKIP_CLOSEST_HIT;
  shadow.cullMask = 0xFFu;
  shadow.missIndex = 1u;
  shadow.sbtOffset = 0u;
  shadow.kind = WF_KIND_SHADOW;
  shadow.pad = 0u;
  wf_emit(shadow, p);
}

// A shadow ray that misses adds its payload (the sun is visible); a primary miss adds the sky.
fn sun_miss(ray: WfRay, payload: Payload) {
  if (ray.kind == WF_KIND_SHADOW) {
    wf_accumulate(ray.pixel, vec3<f32>(bitcast<f32>(payload[0]), bitcast<f32>(payload[1]), bitcast<f32>(payload[2])));
  } else {
    wf_accumulate(ray.pixel, frame.params[SUN_SKY].xyz);
  }
}

fn program_closest_hit(ray: WfRay, hit: HitRecord, payload: Payload) {
  if (PROGRAM == WF_PROGRAM_SUN_SHADOW) {
    sun_hit(ray, hit);
  } else {
    triangle_hit(ray, hit);
  }
}

fn program_miss(ray: WfRay, payload: Payload) {
  if (PROGRAM == WF_PROGRAM_SUN_SHADOW) {
    sun_miss(ray, payload);
  } else {
    triangle_miss(ray);
  }
}

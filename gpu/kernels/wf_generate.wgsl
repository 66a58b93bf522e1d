// GENERATE (DESIGN.md §7): one invocation per pixel clears its accum slot to (0, 0, 0, 1) and runs the program's
// raygen, which for both built-in programs emits the camera's primary ray (the seed's generateRay, §7 "Camera") into
// queue 0. The clear and the raygen share the pass, which is safe because a raygen accumulates nowhere here.
// #include "wf_api.wgsl"

// The primary ray of pixel (x, y) from CameraUniforms, in binary32 term by term as the oracle's rto_camera_ray:
// pixel centres at +0.5, NDC y flipped, matrix x vector summed column by column left to right (the w terms too: the
// 0 w of a direction turns -0 into +0), then normalize(v) = v / length(v). The constants of (ndc, -1, 1) and
// (eye, -1, 0) come from the uniform (wf_common.wgsl says why).
fn camera_ray(x: u32, y: u32) -> WfRay {
  let px = f32(x) + 0.5;
  let py = f32(y) + 0.5;
  let nx = (px / f32(frame.width)) * 2.0 - 1.0;
  let ny = 1.0 - (py / f32(frame.height)) * 2.0;
  let ip = frame.inverseProjection;
  let iv = frame.inverseView;
  let eye = ((ip[0].xy * nx + ip[1].xy * ny) + ip[2].xy * frame.minusOne) + ip[3].xy * frame.one;
  let world = ((iv[0].xyz * eye.x + iv[1].xyz * eye.y) + iv[2].xyz * frame.minusOne) + iv[3].xyz * frame.zero;
  var r: WfRay;
  r.origin = frame.position;
  r.tMin = 0.0;
  r.dir = wf_normalize(world);
  r.tMax = WF_T_MAX;
  r.flags = RAY_FLAG_OPAQUE;
  r.cullMask = 0xFFu;
  r.missIndex = 0u;
  r.sbtOffset = 0u;
  r.kind = WF_KIND_PRIMARY;
  r.pad = 0u;
  return r; // pixel and payloadSlot are the frame's (wf_emit)
}

// Both built-in programs: the camera ray, no payload (the oracle stores zero words).
fn raygen(x: u32, y: u32) {
  var nothing: Payload;
  wf_emit(camera_ray(x, y), nothing);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
  if (gid.x >= frame.width || gid.y >= frame.height) {
    return;
  }
  let p = gid.y * frame.width + gid.x;
  accum[p] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
  wf_begin_invocation(p, p);
  raygen(gid.x, gid.y);
}

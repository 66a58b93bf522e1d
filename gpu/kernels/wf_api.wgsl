// The frame API a program calls (DESIGN.md §7, the seeds' rtEmitPrimaryRay / rtEmitRay / rtAccumulate), shared by
// GENERATE and SHADE: appends to the queue being filled and read-modify-writes of the accum buffer.
// #include "wf_common.wgsl"

@group(0) @binding(2) var<storage, read_write> state: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> accum: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> rays_out: array<WfRay>;
@group(0) @binding(5) var<storage, read_write> payloads_out: array<u32>;

// The invocation being run (raygen of a pixel, or the shading of one ray): its pixel, its item (pixel or ray index:
// conflicts are per item) and how many emits it made.
var<private> inv_pixel: u32;
var<private> inv_item: u32;
var<private> inv_emits: u32;

fn wf_begin_invocation(pixel: u32, item: u32) {
  inv_pixel = pixel;
  inv_item = item;
  inv_emits = 0u;
}

// Appends a ray to queue stage.queueOut. The frame sets pixel and payloadSlot = pixel + j W H (j-th emit of this
// invocation); a third emit is refused. The emit counter counts every append, dropped ones too (an append past
// capacity is dropped and counted): what atomicAdd leaves there is the oracle's emit count. Returns false only when
// refused (the oracle's emit returns 1 for a dropped ray too).
fn wf_emit(r: WfRay, payload: Payload) -> bool {
  let q = stage.queueOut;
  if (inv_emits >= EMITS_PER_INVOCATION) {
    atomicAdd(&state[wf_counter(q, C_REFUSED)], 1u);
    return false;
  }
  var ray = r;
  ray.pixel = inv_pixel;
  ray.payloadSlot = inv_pixel + inv_emits * wf_pixels();
  inv_emits += 1u;
  let at = atomicAdd(&state[STATE_EMIT + q % 2u], 1u);
  if (at >= frame.capacity) {
    atomicAdd(&state[wf_counter(q, C_DROPPED)], 1u);
    return true;
  }
  rays_out[at] = ray;
  for (var k = 0u; k < PAYLOAD_WORDS; k++) {
    payloads_out[ray.payloadSlot * PAYLOAD_WORDS + k] = payload[k];
  }
  return true;
}

// accum[pixel].rgb += rgb, as a plain read-modify-write: two invocations of one pass adding into one pixel race (the
// oracle marks such pixels not comparable). The race is detected, not prevented: each accumulate swaps its item into
// the pixel's owner word; seeing another item of this pass there is a conflict, counted once per pixel per frame
// (the owner words are cleared before every pass).
fn wf_accumulate(pixel: u32, rgb: vec3<f32>) {
  if (pixel >= wf_pixels()) {
    return;
  }
  let a = accum[pixel];
  accum[pixel] = vec4<f32>(a.x + rgb.x, a.y + rgb.y, a.z + rgb.z, a.w);
  atomicAdd(&state[wf_counter(stage.row, C_ACCUMULATES)], 1u);
  let before = atomicExchange(&state[STATE_OWNER + pixel], inv_item + 1u);
  if (before != 0u && before != inv_item + 1u &&
      atomicOr(&state[STATE_OWNER + wf_pixels() + pixel], 1u) == 0u) {
    atomicAdd(&state[wf_counter(stage.row, C_CONFLICTS)], 1u);
  }
}

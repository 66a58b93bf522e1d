// SHADE d (DESIGN.md §7): one invocation per ray of queue d (dispatched indirectly from PREP d's arguments) reads its
// hit record and payload and runs the program: miss -> miss program, hit -> closest hit unless the ray has
// SKIP_CLOSEST_HIT. The programs (wf_programs.wgsl) accumulate into accum and emit rays into queue d + 1.
// #include "wf_api.wgsl"
// #include "wf_programs.wgsl"

@group(0) @binding(6) var<storage, read> rays_in: array<WfRay>;
@group(0) @binding(7) var<storage, read> hits_in: array<HitRecord>;
@group(0) @binding(8) var<storage, read> payloads_in: array<u32>; // slot payloadSlot at PAYLOAD_WORDS * slot

// What a closest-hit program shades (§7 "Surface at a hit"), for meshes without normals, uvs or materials (the only
// ones a bundle carries): shading normal = geometric normal, base colour 1.
struct Surface { position: vec3<f32>, normal: vec3<f32>, baseColor: vec4<f32> }

// position o + t d per component; geometric normal transpose(W2O) cross(v1 - v0, v2 - v0), each row
// ((m0r x + m1r y) + m2r z), then normalised.
fn wf_surface(ray: WfRay, hit: HitRecord) -> Surface {
  var s: Surface;
  s.position = vec3<f32>(ray.origin.x + hit.t * ray.dir.x, ray.origin.y + hit.t * ray.dir.y,
                         ray.origin.z + hit.t * ray.dir.z);
  s.baseColor = vec4<f32>(1.0);
  let tri = instance_triangle(hit.instanceId, hit.primId);
  let e1 = tri.v1 - tri.v0;
  let e2 = tri.v2 - tri.v0;
  let ng = vec3<f32>(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x);
  let r0 = instance_world_to_obj_row(hit.instanceId, 0u).xyz;
  let r1 = instance_world_to_obj_row(hit.instanceId, 1u).xyz;
  let r2 = instance_world_to_obj_row(hit.instanceId, 2u).xyz;
  s.normal = wf_normalize((r0 * ng.x + r1 * ng.y) + r2 * ng.z);
  return s;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
  let i = gid.x;
  if (i >= atomicLoad(&state[STATE_QUEUE_LEN])) {
    return;
  }
  let ray = rays_in[i];
  let hit = hits_in[i];
  var payload: Payload;
  for (var k = 0u; k < PAYLOAD_WORDS; k++) {
    payload[k] = payloads_in[ray.payloadSlot * PAYLOAD_WORDS + k];
  }
  wf_begin_invocation(ray.pixel, i);
  let row = stage.row;
  if (hit.missFlag != 0u) {
    atomicAdd(&state[wf_counter(row, C_MISSES)], 1u);
    atomicAdd(&state[wf_counter(row, C_SHADED)], 1u);
    program_miss(ray, payload);
  } else {
    atomicAdd(&state[wf_counter(row, C_HITS)], 1u);
    if ((ray.flags & RAY_FLAG_SKIP_CLOSEST_HIT) == 0u) {
      atomicAdd(&state[wf_counter(row, C_SHADED)], 1u);
      program_closest_hit(ray, hit, payload);
    }
  }
}

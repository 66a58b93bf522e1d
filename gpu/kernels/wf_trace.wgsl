// TRACE d (DESIGN.md §6, §7): one invocation per ray of queue d (dispatched indirectly from PREP d's arguments)
// traces it with the shared ordered traversal (trace.wgsl, the scene in group 1) and writes its hit record at the
// ray's index. No program code runs here. A ray trace_ray refuses or cannot finish (its status) is counted: the
// harness fails the frame on any.
// #include "wf_common.wgsl"
// #include "trace.wgsl"

@group(0) @binding(2) var<storage, read_write> state: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read> rays: array<WfRay>;
@group(0) @binding(4) var<storage, read_write> hits: array<HitRecord>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
  let i = gid.x;
  if (i >= atomicLoad(&state[STATE_QUEUE_LEN])) {
    return;
  }
  atomicAdd(&state[wf_counter(stage.queueIn, C_TRACED)], 1u);
  let traced = trace_ray(rays[i]);
  hits[i] = traced.hit;
  if (traced.status != 0u) {
    atomicAdd(&state[STATE_TRACE_FAULTS], 1u);
  }
}

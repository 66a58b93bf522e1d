// TRACE as its own kernel (DESIGN.md §6): one ray per invocation, 64 per workgroup. Ray i's hit record, counters
// and trace status (trace.wgsl's TRACE_STATUS_* bits; 0 = traced) go to slot i of their buffers, every slot written.
// The scene is group 1 (scene.wgsl). A dispatch of more than 65,535 workgroups spreads over y; the x size of the
// grid tells the row length.
// #include "trace.wgsl"

@group(0) @binding(0) var<storage, read> rays: array<WfRay>;
@group(0) @binding(1) var<storage, read_write> hits: array<HitRecord>;
@group(0) @binding(2) var<storage, read_write> counters: array<TraceCounters>;
@group(0) @binding(3) var<storage, read_write> status: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
  let i = gid.y * groups.x * 64u + gid.x;
  if (i >= arrayLength(&rays)) { return; }
  let res = trace_ray(rays[i]);
  hits[i] = res.hit;
  counters[i] = res.counters;
  status[i] = res.status;
}

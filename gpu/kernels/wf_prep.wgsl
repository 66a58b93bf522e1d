// PREP d (DESIGN.md §7): one invocation turns the emit counter of the queue just filled into its length
// n = min(count, capacity) and PREP's indirect dispatch arguments [ceil(n / 64), 1, 1] (TRACE d and SHADE d are
// dispatched from them), records the queue's emitted / queued counters, and resets the other ping-pong counter for
// the queue SHADE d fills next. It is its own pass because atomics written by one dispatch are only visible to the
// next one.
// #include "wf_common.wgsl"

@group(0) @binding(2) var<storage, read_write> state: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> indirect: array<u32>; // 3 words per queue: indirect_args.npy

@compute @workgroup_size(1)
fn main() {
  let d = stage.queueIn;
  let count = atomicLoad(&state[STATE_EMIT + d % 2u]);
  let n = min(count, frame.capacity);
  atomicStore(&state[STATE_QUEUE_LEN], n);
  atomicStore(&state[wf_counter(d, C_EMITTED)], count);
  atomicStore(&state[wf_counter(d, C_QUEUED)], n);
  indirect[3u * d] = (n + 63u) / 64u;
  indirect[3u * d + 1u] = 1u;
  indirect[3u * d + 2u] = 1u;
  atomicStore(&state[STATE_EMIT + (d + 1u) % 2u], 0u);
}

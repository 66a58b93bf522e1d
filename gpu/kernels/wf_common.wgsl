// What every stage of the wavefront frame shares (DESIGN.md §7): the frame's uniforms, the layout of the state
// buffer (emit counters, FrameCounters rows, per-pixel conflict words) and the queue/counter arithmetic.
// The including kernel gets these defines from gpu/lib/frame.js: MAX_DEPTH, PAYLOAD_WORDS, PROGRAM.
// #include "scene.wgsl"

// The frame's constants (one uniform block for every pass).
struct Frame {
  width: u32, height: u32, capacity: u32, maxDepth: u32,
  rayOffset: f32,
  // 1, -1 and 0, the w and z of the camera's homogeneous vectors: read from here, not written as literals, so that
  // a shader compiler cannot see them and rewrite the sums they take part in (Mesa reassociates x + y * -1.0).
  one: f32, minusOne: f32, zero: f32,
  // CameraUniforms (camera.npy): column-major, column c = inverseProjection[c].
  inverseProjection: mat4x4<f32>,
  inverseView: mat4x4<f32>,
  position: vec3<f32>, pad3: f32,
  // The program's parameters in the manifest's order, one vec4 each (.xyz used).
  params: array<vec4<f32>, 4>,
}

// What one pass works on: the queue it reads (PREP, TRACE, SHADE d: d), the queue it fills (GENERATE: 0, SHADE d:
// d + 1) and the FrameCounters row of its hits, misses, shaded, accumulates and conflicts (GENERATE: 0, SHADE d: d).
struct Stage { queueIn: u32, queueOut: u32, row: u32, pad: u32 }

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<uniform> stage: Stage;

const WF_PROGRAM_TRIANGLE = 0u;
const WF_PROGRAM_SUN_SHADOW = 1u;
const WF_KIND_PRIMARY = 0u;
const WF_KIND_SHADOW = 1u;
const WF_T_MAX = 1e30f;
// The seeds' per-invocation emit budget: a third emit is refused (counted, never stored, never in the emit counter).
const EMITS_PER_INVOCATION = 2u;
// A payload is carried as words; the built-in programs use PAYLOAD_WORDS of them (sun-shadow 3, triangle 0).
const PAYLOAD_MAX_WORDS = 16u;
alias Payload = array<u32, PAYLOAD_MAX_WORDS>;

// The state buffer (u32 words, atomics; cleared before GENERATE):
//   STATE_EMIT + 0/1     the ping-pong emit counters: queue d appends on STATE_EMIT + d % 2
//   STATE_QUEUE_LEN      n of the queue the last PREP prepared (bounds TRACE and SHADE)
//   STATE_TRACE_FAULTS   rays trace_ray refused or could not finish (its status): none in a frame the oracle rendered
//   STATE_COUNTERS       FrameCounters, 10 words per queue d = 0 .. MAX_DEPTH (the rows of frame_counters.npy)
//   STATE_OWNER          W H words: the last invocation (item + 1) that accumulated into each pixel in this pass
//   STATE_OWNER + W H    W H words: 1 once the pixel had a conflict (two invocations of one pass accumulating)
const STATE_EMIT = 0u;
const STATE_QUEUE_LEN = 2u;
const STATE_TRACE_FAULTS = 3u;
const STATE_COUNTERS = 4u;
const COUNTER_WORDS = 10u;
const STATE_OWNER = STATE_COUNTERS + COUNTER_WORDS * (MAX_DEPTH + 1u);
const C_EMITTED = 0u;
const C_QUEUED = 1u;
const C_DROPPED = 2u;
const C_REFUSED = 3u;
const C_TRACED = 4u;
const C_HITS = 5u;
const C_MISSES = 6u;
const C_SHADED = 7u;
const C_ACCUMULATES = 8u;
const C_CONFLICTS = 9u;

// The state word of field f of queue d's FrameCounters row.
fn wf_counter(d: u32, f: u32) -> u32 { return STATE_COUNTERS + d * COUNTER_WORDS + f; }

fn wf_pixels() -> u32 { return frame.width * frame.height; }

// §6's dot, summed left to right: (a.x b.x + a.y b.y) + a.z b.z.
fn wf_dot3(a: vec3<f32>, b: vec3<f32>) -> f32 { return (a.x * b.x + a.y * b.y) + a.z * b.z; }

// §7's normalize(v) = v / length(v), length = sqrt(wf_dot3(v, v)) (not the builtin, whose rounding is unspecified).
fn wf_normalize(v: vec3<f32>) -> vec3<f32> {
  let len = sqrt(wf_dot3(v, v));
  return vec3<f32>(v.x / len, v.y / len, v.z / len);
}

// The canonical bitonic network (DESIGN.md §4) run by ONE workgroup over up to 16384 u32 keys in storage, with a
// barrier between every two (k, j) passes: the seeds' lbvhBuildMain shape. Invocation t owns pairs t, t + WG, ...
// of each pass; pair q is slot i = q with a 0 inserted at bit j, and its partner l = i | j, so the n/2 pairs cover
// every slot exactly once and no two invocations touch one slot within a pass.
// With p.dump != 0 each invocation also writes the pair it just produced into row `pass` of `passes` (passes x n):
// that row is exactly what the pass computed, so it needs no extra barrier and shows where a race first bites.
// DROP_BARRIER (a define; 0xFFFFFFFF for none) runs the pass after that one with no barrier in between: a planted
// race. It is left out of the code path rather than skipped by a branch, because llvmpipe runs a branch's body, its
// barrier included, under an execution mask even when no invocation takes it.
struct Params { n: u32, dump: u32, pad0: u32, pad1: u32 }
@group(0) @binding(0) var<storage, read_write> keys: array<u32>;
@group(0) @binding(1) var<storage, read_write> passes: array<u32>;
@group(0) @binding(2) var<uniform> p: Params;

const WG = 128u; // the compat limit on invocations per workgroup

/** This invocation's compare-exchanges of pass (k, j), the pass_index-th of the schedule. */
fn exchange(t: u32, k: u32, j: u32, pass_index: u32) {
  for (var q = t; q < p.n / 2u; q += WG) {
    let i = ((q & ~(j - 1u)) << 1u) | (q & (j - 1u));
    let l = i | j;
    var a = keys[i];
    var b = keys[l];
    let ascending = (i & k) == 0u;
    if ((ascending && a > b) || (!ascending && a < b)) {
      let s = a;
      a = b;
      b = s;
      keys[i] = a;
      keys[l] = b;
    }
    if (p.dump != 0u) {
      passes[pass_index * p.n + i] = a;
      passes[pass_index * p.n + l] = b;
    }
  }
}

/** The pass after (k, j) in the schedule: j halves down to 1, then k doubles and j restarts at k / 2. */
fn next_pass(kj: vec2<u32>) -> vec2<u32> {
  if (kj.y > 1u) {
    return vec2<u32>(kj.x, kj.y >> 1u);
  }
  return vec2<u32>(kj.x << 1u, kj.x);
}

@compute @workgroup_size(WG)
fn main(@builtin(local_invocation_index) t: u32) {
  var kj = vec2<u32>(2u, 1u);
  for (var pass_index = 0u; kj.x <= p.n; pass_index++) {
    exchange(t, kj.x, kj.y, pass_index);
    if (pass_index == DROP_BARRIER && next_pass(kj).x <= p.n) {
      kj = next_pass(kj);
      pass_index++;
      exchange(t, kj.x, kj.y, pass_index);
    }
    // Every invocation is past this pass's writes before any reads the next pass's pairs (storageBarrier is a
    // control barrier as well as a storage-memory one).
    storageBarrier();
    kj = next_pass(kj);
  }
}

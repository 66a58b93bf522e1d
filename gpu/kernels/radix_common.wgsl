// Shared by the radix kernels (DESIGN.md §4, LSD radix reference): 4-bit digits, a tile of TILE keys per workgroup
// of WG invocations, and the per-pass parameters. Arrays indexed (pass, tile, digit) hold every pass, so the
// harness reads all of them back once and compares them with the oracle's radix_hist / radix_prefix / radix_base.
struct Params { n: u32, tiles: u32, shift: u32, pass_index: u32 }

const RADIX = 16u; // 2^4 digit values
const WG = 128u;   // the compat limit on invocations per workgroup
const TILE = 256u; // keys per tile: two per invocation (the oracle's --tile)

/** The digit of key at this pass's shift. */
fn digit_of(key: u32, shift: u32) -> u32 {
  return (key >> shift) & (RADIX - 1u);
}

/** Offset of (pass, tile, digit 0) in a (passes, tiles, RADIX) array. */
fn tile_row(p: Params, tile: u32) -> u32 {
  return (p.pass_index * p.tiles + tile) * RADIX;
}

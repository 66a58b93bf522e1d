/* The raymarch's private interface (DESIGN.md §12.4-§12.7): what check_raymarch.c and raymarch_bundle.c share with
 * raymarch.c. */
#ifndef RTO_RAYMARCH_INTERNAL_H
#define RTO_RAYMARCH_INTERNAL_H

#include "rtoracle.h"

/* After the public header: its declarations keep default visibility (a hidden redeclaration would hide them from the
 * shared library under link-time optimisation). */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** The occupancy levels of O cells per axis (§12.3): levels down to one cell, each level's first word and cells per
 * axis, and the total words. Returns the level count (at most 12), 0 when O is out of range. */
uint32_t rto__rm_levels(uint32_t O, uint64_t level_offset[12], uint32_t level_res[12], uint64_t *words);

/** Whether cell (x, y, z) of level l of vol's occupancy is set (bits read directly, §12.3). */
int rto__rm_occ(const rto_splat *vol, uint32_t l, uint32_t x, uint32_t y, uint32_t z);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif

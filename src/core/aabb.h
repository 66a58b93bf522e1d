/* The library's private box helpers beside the public ones of rtoracle.h (core/aabb.c is their one home). */
#ifndef RTO_CORE_AABB_H
#define RTO_CORE_AABB_H

#include "rtoracle.h"

/* Library-private: not exported from librtoracle.so. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** 1 if some bound is NaN: an invalid box, which no rule calls empty (rto_aabb_is_empty) or finite. */
int rto__aabb_has_nan(const rto_aabb *box);
/** The box of min / max triples (a tree node's or a GPU record's). */
rto_aabb rto__aabb_of(const float mn[3], const float mx[3]);
/** Grows a box to hold p (rto__minf / rto__maxf: the later operand when equal, so unions are the same bytes). */
void rto__aabb_grow(rto_aabb *box, rto_vec3 p);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif

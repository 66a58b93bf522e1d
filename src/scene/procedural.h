/* The procedural loader (procedural.c): scenes named on the command line where a path would go. */
#ifndef RTO_PROCEDURAL_H
#define RTO_PROCEDURAL_H

#include "rtoracle.h"

/* Library-private (like internal.h): not exported from librtoracle.so. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

/** 1 if spec names a procedural scene kind ("triangle", "rtstress:...", "instances:...", "sphere:...",
 * "random:..."), valid or not. */
int rto__procedural_is(const char *spec);

/** Fills an empty scene from a procedural spec ("triangle", "rtstress:N", "instances:DIST:N", "sphere:L[:SEED]",
 * "random:SEED"); every failure message quotes the spec. */
rto_status rto__procedural_load(const char *spec, rto_scene *scene, rto_msg *msg);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif

/* The Embree module's entry point (embree_module.h): embree.c's functions in one table. Built with embree.c into
 * librto_embree.so, which rtoracle loads on demand for crosscheck. */
#include "embree.h"

#include <stdio.h>

#define EMB_STR2(x) #x
#define EMB_STR(x) EMB_STR2(x)

__attribute__((visibility("default"))) const emb_module *rto_embree_module(void);

const emb_module *rto_embree_module(void)
{
    static const emb_module m = {
        EMB_MODULE_ABI,
        EMB_STR(RTC_VERSION_MAJOR) "." EMB_STR(RTC_VERSION_MINOR) "." EMB_STR(RTC_VERSION_PATCH),
        emb_device_create,
        emb_device_destroy,
        emb_scene_create,
        emb_scene_destroy,
        emb_trace,
        emb_trace_closest,
        emb_thread_count,
        emb_quality_name,
    };
    return &m;
}

/* Embree for `rtoracle crosscheck`, as a module loaded on demand (librto_embree.so): only crosscheck uses Embree, so
 * the rtoracle binary does not link it, and a GPU host that dumps and checks needs neither Embree (44 MB) nor its
 * dependencies. The module is oracle/embree.c behind one table of functions (embree.h documents each); the tests and
 * benchmarks link embree.c directly.
 *
 * Search order of emb_module_load: $RTO_EMBREE_MODULE, beside the running executable, the install layout's place
 * relative to it (<exe>/../<libdir>/rtoracle/librto_embree.so), then the build tree and the install directory (paths
 * fixed at configure time): an installed tree copied elsewhere uses its own module. */
#ifndef RTO_ORACLE_EMBREE_MODULE_H
#define RTO_ORACLE_EMBREE_MODULE_H

#include "rtoracle.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct emb_device emb_device;
typedef struct emb_scene emb_scene;

/** Build quality of every scene and geometry of a mirror. Zero means the default (MEDIUM, Embree's own default). */
typedef enum emb_quality {
    EMB_QUALITY_DEFAULT = 0,
    EMB_QUALITY_LOW = 1,    /* Morton builder (both scene and geometry must ask for it) */
    EMB_QUALITY_MEDIUM = 2, /* binned SAH */
    EMB_QUALITY_HIGH = 3    /* SAH with spatial splits */
} emb_quality;

/** How to mirror a scene. Zero-initialised means the defaults (MEDIUM, not robust, no culling). */
typedef struct emb_scene_desc {
    emb_quality quality; /* set on every scene (rtcSetSceneBuildQuality) and every geometry
                          * (rtcSetGeometryBuildQuality): Embree takes the geometry's builder only when both ask */
    bool robust;         /* RTC_SCENE_FLAG_ROBUST on every scene: watertight Plücker triangle tests and conservative
                          * box tests, the mode the oracle's results are checked against by default */
    bool culling;        /* intersection filters that honour CULL_BACK_FACING / CULL_FRONT_FACING (slower) */
} emb_scene_desc;

#define EMB_MODULE_ABI 1
#define EMB_MODULE_SYMBOL "rto_embree_module"

/** The module's functions: embree.h's of the same names. */
typedef struct emb_module {
    int abi;             /* EMB_MODULE_ABI */
    const char *version; /* Embree's, "3.13.5" */
    rto_status (*device_create)(uint32_t threads, const char *extra, emb_device **out, rto_msg *msg);
    void (*device_destroy)(emb_device *d);
    rto_status (*scene_create)(emb_device *d, const rto_scene *scene, const emb_scene_desc *desc, emb_scene **out,
                               rto_msg *msg);
    void (*scene_destroy)(emb_scene *s);
    rto_status (*trace)(const emb_scene *s, emb_device *d, const rto_wf_ray *rays, size_t n, uint32_t threads,
                        rto_hit_record *hits, rto_msg *msg);
    void (*trace_closest)(const emb_scene *s, const rto_wf_ray *ray, rto_hit_record *hit);
    uint32_t (*thread_count)(uint32_t threads);
    const char *(*quality_name)(emb_quality q);
} emb_module;

/** The module's entry point (EMB_MODULE_SYMBOL). */
typedef const emb_module *(*emb_module_fn)(void);

/** Loads the module once (later calls return the same table): NULL with a one-line reason in msg
 * (RTO_ERR_UNSUPPORTED) when it is not found or not compatible. */
const emb_module *emb_module_load(rto_msg *msg);

#endif

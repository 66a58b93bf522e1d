/* Loading the Embree module on demand (embree_module.h): the one dlopen of librto_embree.so, the first time crosscheck
 * needs it. */
#include "embree_module.h"

#include "core/internal.h"

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

const emb_module *emb_module_load(rto_msg *msg)
{
    static const emb_module *loaded;
    if (loaded)
        return loaded;
    const char *paths[RTO_MODULE_PATHS];
    char rel[2][4096];
    const size_t n = rto__module_paths("RTO_EMBREE_MODULE", "librto_embree.so", RTO_EMBREE_MODULE_RELATIVE,
                                       RTO_EMBREE_MODULE_BUILD, RTO_EMBREE_MODULE_INSTALL, paths, rel);
    for (size_t i = 0; i < n; i++) {
        if (access(paths[i], R_OK) != 0)
            continue;
        void *h = dlopen(paths[i], RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            const char *e = dlerror();
            rto_msg_set(msg, RTO_ERR_UNSUPPORTED, "cannot load %s: %s", paths[i], e ? e : "dlopen failed");
            return NULL;
        }
        emb_module_fn fn = NULL;
        void *sym = dlsym(h, EMB_MODULE_SYMBOL);
        if (sym)
            memcpy(&fn, &sym, sizeof fn); /* the conversion POSIX guarantees, without the cast ISO C forbids */
        const emb_module *m = fn ? fn() : NULL;
        if (!m || m->abi != EMB_MODULE_ABI) {
            rto_msg_set(msg, RTO_ERR_UNSUPPORTED, "%s is not a compatible Embree module (ABI %d wanted)", paths[i],
                        EMB_MODULE_ABI);
            dlclose(h);
            return NULL;
        }
        loaded = m; /* stays loaded for the life of the process */
        return m;
    }
    rto_msg_set(msg, RTO_ERR_UNSUPPORTED, "crosscheck needs the Embree module librto_embree.so (and Embree 3): not "
                "found beside the executable, in ../%s from it, in the build tree or in %s (set RTO_EMBREE_MODULE)",
                RTO_EMBREE_MODULE_RELATIVE, RTO_EMBREE_MODULE_INSTALL);
    return NULL;
}

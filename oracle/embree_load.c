/* Loading the Embree module on demand (embree_module.h): the one dlopen of librto_embree.so, the first time crosscheck
 * needs it. */
#include "embree_module.h"

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
    /* the search order of the image module's loader (the library's rto__module_paths, which the command, a user
     * of the public header only, cannot call): $RTO_EMBREE_MODULE, beside the executable, the install layout's place
     * relative to it, the build tree, the configured install path */
    const char *env = getenv("RTO_EMBREE_MODULE"), *paths[5];
    char rel[2][4096], exe[4096];
    size_t n = 0;
    if (env && *env)
        paths[n++] = env;
    const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    char *slash = len > 0 ? (exe[len] = 0, strrchr(exe, '/')) : NULL;
    if (slash) {
        *slash = 0;
        if (snprintf(rel[0], sizeof rel[0], "%s/librto_embree.so", exe) < (int)sizeof rel[0])
            paths[n++] = rel[0];
        if (snprintf(rel[1], sizeof rel[1], "%s/../%s", exe, RTO_EMBREE_MODULE_RELATIVE) < (int)sizeof rel[1])
            paths[n++] = rel[1];
    }
    paths[n++] = RTO_EMBREE_MODULE_BUILD;
    paths[n++] = RTO_EMBREE_MODULE_INSTALL;
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

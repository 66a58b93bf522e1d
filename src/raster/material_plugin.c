/* Material plugins (DESIGN.md §11.5): a user's material, ported from WGSL to one C function in a shared library that
 * exports RTO_MATERIAL_ENTRY_SYMBOL, loaded by `vbuffer --material lib.so` and `check-vbuffer --material lib.so`. */
#include "internal.h"

#include <dlfcn.h>
#include <stdlib.h>
#include <string.h>

struct rto_material_plugin {
    void *handle;
    const rto_material_def *def;
};

static int name_ok(const char *n)
{
    if (!n || !*n || strlen(n) > 48)
        return 0;
    for (const char *c = n; *c; c++)
        if (!((*c >= 'a' && *c <= 'z') || (*c >= '0' && *c <= '9') || *c == '-'))
            return 0;
    return 1;
}

rto_status rto_material_plugin_load(const char *path, rto_material_plugin **out, rto_msg *msg)
{
    if (!path || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL material plugin path or output");
    *out = NULL;
    void *h;
    union {
        void *p;
        rto_material_entry_fn f;
    } entry;
    rto_status s = rto__plugin_open(path, RTO_MATERIAL_ENTRY_SYMBOL, "material plugin", &h, &entry.p, msg);
    if (s)
        return s;
    const rto_material_def *def = entry.f();
    const char *why = !def                                         ? "its entry returned no material"
                      : def->abi_version != RTO_MATERIAL_ABI_VERSION ? "another material ABI version"
                      : !name_ok(def->name)                        ? "its name is not 1-48 of [a-z0-9-]"
                      : !def->shade                                ? "it has no shade function"
                                                                   : NULL;
    if (why) {
        dlclose(h);
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: %s", path, why);
    }
    rto_material_plugin *pl = calloc(1, sizeof *pl);
    if (!pl) {
        dlclose(h);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    pl->handle = h;
    pl->def = def;
    *out = pl;
    return RTO_OK;
}

const rto_material_def *rto_material_plugin_def(const rto_material_plugin *plugin)
{
    return plugin ? plugin->def : NULL;
}

void rto_material_plugin_unload(rto_material_plugin *plugin)
{
    if (!plugin)
        return;
    dlclose(plugin->handle);
    free(plugin);
}

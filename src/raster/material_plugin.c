/* Material plugins (DESIGN.md §11.5): a user's material, ported from WGSL to one C function in a shared library that
 * exports RTO_MATERIAL_ENTRY_SYMBOL, loaded by `vbuffer --material lib.so` and `check-vbuffer --material lib.so`. */
#include "internal.h"

#include <dlfcn.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

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
    struct stat st;
    if (stat(path, &st))
        return rto__fail(msg, RTO_ERR_IO, "%s: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return rto__fail(msg, RTO_ERR_IO, "%s: not a regular file", path);
    /* A name without a slash would make dlopen search the library path: always name the file itself. */
    char local[4096];
    snprintf(local, sizeof local, "%s%s", strchr(path, '/') ? "" : "./", path);
    dlerror();
    void *h = dlopen(local, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *e = dlerror();
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: cannot load: %s", path, e ? e : "dlopen failed");
    }
    union {
        void *p;
        rto_material_entry_fn f;
    } entry = {dlsym(h, RTO_MATERIAL_ENTRY_SYMBOL)};
    const rto_material_def *def = entry.p ? entry.f() : NULL;
    const char *why = !entry.p                                     ? "no " RTO_MATERIAL_ENTRY_SYMBOL " symbol (not an "
                                                                     "rtoracle material plugin, or another ABI)"
                      : !def                                       ? "its entry returned no material"
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

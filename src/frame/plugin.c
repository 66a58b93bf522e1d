/* Programs from shared libraries: a user ports their WGSL closest-hit / miss programs to C, builds them as a shared
 * library exporting RTO_PROGRAM_ENTRY_SYMBOL, and passes it to `rtoracle render --program lib.so`. The plugin calls
 * the frame only through the function table in its ctx, so it needs rtoracle.h and nothing to link against. */
#include "frame_internal.h"

#include <dlfcn.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

struct rto_plugin {
    void *handle;
    const rto_program *program;
};

rto_status rto__plugin_open(const char *path, const char *symbol, const char *what, void **handle, void **entry,
                            rto_msg *msg)
{
    *handle = *entry = NULL;
    struct stat st;
    if (stat(path, &st))
        return rto__fail(msg, RTO_ERR_IO, "%s: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return rto__fail(msg, RTO_ERR_IO, "%s: not a regular file", path);
    /* A name without a slash would make dlopen search the library path: always name the file itself. */
    char *local = NULL;
    if (!strchr(path, '/')) {
        local = malloc(strlen(path) + 3);
        if (!local)
            return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
        strcpy(local, "./");
        strcat(local, path);
    }
    dlerror();
    void *h = dlopen(local ? local : path, RTLD_NOW | RTLD_LOCAL);
    free(local);
    if (!h) {
        const char *e = dlerror();
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: cannot load: %s", path, e ? e : "dlopen failed");
    }
    void *sym = dlsym(h, symbol);
    if (!sym) {
        dlclose(h);
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: no %s symbol (not an rtoracle %s, or another ABI)", path, symbol,
                        what);
    }
    *handle = h;
    *entry = sym;
    return RTO_OK;
}

rto_status rto_plugin_load(const char *path, rto_plugin **out, rto_msg *msg)
{
    if (!path || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL plugin path or output");
    *out = NULL;
    void *h;
    union {
        void *p;
        rto_program_entry_fn f;
    } entry;
    rto_status s = rto__plugin_open(path, RTO_PROGRAM_ENTRY_SYMBOL, "program plugin", &h, &entry.p, msg);
    if (s)
        return s;
    const rto_program *prog = entry.f();
    rto_msg why = {{0}};
    if (rto_program_validate(prog, &why)) {
        dlclose(h);
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "%s: %s", path, why.text);
    }
    rto_plugin *pl = calloc(1, sizeof *pl);
    if (!pl) {
        dlclose(h);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    }
    pl->handle = h;
    pl->program = prog;
    *out = pl;
    return RTO_OK;
}

const rto_program *rto_plugin_program(const rto_plugin *plugin) { return plugin ? plugin->program : NULL; }

void rto_plugin_unload(rto_plugin *plugin)
{
    if (!plugin)
        return;
    dlclose(plugin->handle);
    free(plugin);
}

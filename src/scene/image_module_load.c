/* The one place that loads the image module (image_module.h says why it is a module): the glTF loader's textures and
 * io/image.c's image files share one dlopen, made the first time either needs it. A failure is remembered, so every
 * later caller reports the same reason without trying again. */
#include "internal.h"
#include "scene/image_module.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static rto_image_module g_module;
static const rto_image_module *g_loaded;
static char g_error[512];
static pthread_once_t g_once = PTHREAD_ONCE_INIT;

/* dlsym returns an object pointer; copying its bytes into a function pointer is the conversion POSIX guarantees,
 * without the cast ISO C forbids. */
static int symbol(void *h, const char *name, void *fn, size_t size)
{
    void *p = dlsym(h, name);
    if (!p)
        return 0;
    memcpy(fn, &p, size);
    return 1;
}

size_t rto__module_paths(const char *env_name, const char *file, const char *relative, const char *build,
                         const char *install, const char *paths[RTO_MODULE_PATHS], char rel[2][4096])
{
    const char *env = getenv(env_name);
    size_t n = 0;
    if (env && *env)
        paths[n++] = env;
    char exe[4096];
    const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    char *slash = len > 0 ? (exe[len] = 0, strrchr(exe, '/')) : NULL;
    if (slash) {
        *slash = 0;
        if (snprintf(rel[0], 4096, "%s/%s", exe, file) < 4096)
            paths[n++] = rel[0];
        if (snprintf(rel[1], 4096, "%s/../%s", exe, relative) < 4096)
            paths[n++] = rel[1];
    }
    paths[n++] = build;
    paths[n++] = install;
    return n;
}

/* The image module's places (rto__module_paths): $RTO_IMAGE_MODULE, beside the executable, the install layout's
 * place relative to it (<exe dir>/../<libdir>/rtoracle/librto_image.so), the build tree, the install directory. */
static size_t module_paths(const char *paths[RTO_MODULE_PATHS], char rel[2][4096])
{
    return rto__module_paths("RTO_IMAGE_MODULE", "librto_image.so", RTO_IMAGE_MODULE_RELATIVE, RTO_IMAGE_MODULE_BUILD,
                             RTO_IMAGE_MODULE_INSTALL, paths, rel);
}

const char *rto__image_module_path(void)
{
    static char rel[2][4096];
    const char *paths[RTO_MODULE_PATHS];
    const size_t n = module_paths(paths, rel);
    for (size_t i = 0; i < n; i++)
        if (access(paths[i], R_OK) == 0)
            return paths[i];
    return NULL;
}

static void load(void)
{
    static char rel[2][4096];
    const char *paths[RTO_MODULE_PATHS];
    const size_t n = module_paths(paths, rel);
    for (size_t i = 0; i < n; i++) {
        const char *p = paths[i];
        if (access(p, R_OK) != 0)
            continue;
        /* Lazily bound: OpenImageIO pulls in some 250 libraries, and resolving every function of them up front took a
         * quarter of each image command's 0.5 s. */
        void *h = dlopen(p, RTLD_LAZY | RTLD_LOCAL);
        if (!h) {
            const char *e = dlerror();
            snprintf(g_error, sizeof g_error, "cannot load %s: %s", p, e ? e : "dlopen failed");
            return;
        }
        rto_image_abi_fn abi = NULL;
        rto_image_module m = {0};
        int ok = symbol(h, RTO_IMAGE_MODULE_ABI_SYMBOL, &abi, sizeof abi) && abi() == RTO_IMAGE_MODULE_ABI &&
                 symbol(h, RTO_IMAGE_MODULE_DECODE_SYMBOL, &m.decode_rgba, sizeof m.decode_rgba) &&
                 symbol(h, RTO_IMAGE_MODULE_PROBE_SYMBOL, &m.probe, sizeof m.probe) &&
                 symbol(h, RTO_IMAGE_MODULE_READ_SYMBOL, &m.read, sizeof m.read) &&
                 symbol(h, RTO_IMAGE_MODULE_ENCODE_SYMBOL, &m.encode, sizeof m.encode) &&
                 symbol(h, RTO_IMAGE_MODULE_COMPARE_SYMBOL, &m.compare, sizeof m.compare);
        if (!ok) {
            snprintf(g_error, sizeof g_error, "%s is not a compatible image module (ABI %d wanted)", p,
                     RTO_IMAGE_MODULE_ABI);
            dlclose(h);
            return;
        }
        g_module = m;
        g_loaded = &g_module; /* the module stays loaded for the life of the process */
        return;
    }
    snprintf(g_error, sizeof g_error, "image module librto_image.so not found (looked beside the executable, in ../%s "
             "from it, in the build tree and in %s; set RTO_IMAGE_MODULE)", RTO_IMAGE_MODULE_RELATIVE,
             RTO_IMAGE_MODULE_INSTALL);
}

const rto_image_module *rto__image_module(const char **error)
{
    pthread_once(&g_once, load);
    if (!g_loaded && error)
        *error = g_error;
    return g_loaded;
}

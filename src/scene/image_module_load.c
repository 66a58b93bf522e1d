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

const char *rto__image_module_path(void)
{
    const char *env = getenv("RTO_IMAGE_MODULE");
    const char *paths[] = {env && *env ? env : NULL, RTO_IMAGE_MODULE_BUILD, RTO_IMAGE_MODULE_INSTALL};
    for (size_t i = 0; i < sizeof paths / sizeof paths[0]; i++)
        if (paths[i] && access(paths[i], R_OK) == 0)
            return paths[i];
    return NULL;
}

static void load(void)
{
    const char *env = getenv("RTO_IMAGE_MODULE");
    const char *paths[] = {env && *env ? env : NULL, RTO_IMAGE_MODULE_BUILD, RTO_IMAGE_MODULE_INSTALL};
    for (size_t i = 0; i < sizeof paths / sizeof paths[0]; i++) {
        const char *p = paths[i];
        if (!p || access(p, R_OK) != 0)
            continue;
        void *h = dlopen(p, RTLD_NOW | RTLD_LOCAL);
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
    snprintf(g_error, sizeof g_error, "image module librto_image.so not found (set RTO_IMAGE_MODULE)");
}

const rto_image_module *rto__image_module(const char **error)
{
    pthread_once(&g_once, load);
    if (!g_loaded && error)
        *error = g_error;
    return g_loaded;
}

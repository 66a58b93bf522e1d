/* Loading by spec (DESIGN.md §5): a procedural name or a glTF path goes to its loader, and what comes back is
 * validated against the scene model (model.c) before the caller sees it. */
#include "internal.h"
#include "gltf.h"
#include "model.h"
#include "procedural.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    if (n < k)
        return 0;
    for (size_t i = 0; i < k; i++)
        if (tolower((unsigned char)s[n - k + i]) != tolower((unsigned char)suffix[i]))
            return 0;
    return 1;
}

rto_status rto_scene_load_ex(const char *spec, const rto_scene_load_desc *desc, rto_scene **out, rto_msg *msg)
{
    if (out)
        *out = NULL;
    if (!spec || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL scene spec or output");
    if (!*spec)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "empty scene spec");
    rto_scene_load_desc opts;
    rto__load_desc_resolve(desc, &opts);
    rto_scene *s = calloc(1, sizeof *s);
    if (!s)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "out of memory");
    /* A path is bytes, not text: what lands in the scene (and in JSON downstream) is valid UTF-8. */
    rto__utf8_copy(s->source, sizeof s->source, spec, strlen(spec));
    rto_msg why = {{0}};
    rto_status st;
    /* Procedural names first, so that a directory with ':' in its name still loads its .gltf; a ':' spec that names
     * no known procedural scene goes to the procedural loader for its one-line refusal. */
    const int file = !rto__procedural_is(spec) && (ends_with_ci(spec, ".gltf") || ends_with_ci(spec, ".glb"));
    if (rto__procedural_is(spec))
        st = rto__procedural_load(spec, s, &why);
    else if (file)
        st = rto__gltf_load(spec, &opts, s, &why);
    else if (strchr(spec, ':'))
        st = rto__procedural_load(spec, s, &why);
    else
        st = rto__fail(&why, RTO_ERR_INVALID_ARGUMENT,
                      "'%.200s' is neither a .gltf / .glb path nor a procedural scene (triangle, rtstress:N, "
                      "instances:DIST:N, sphere:L[:SEED], random:SEED)",
                      spec);
    if (!st)
        st = rto__scene_validate(s, &why);
    if (st) {
        rto_scene_destroy(s);
        /* The one place a file's failure is prefixed with its path, so no message names it twice; procedural
         * messages quote their spec already. */
        if (file)
            rto__fail(msg, st, "%.200s: %s", spec, why.text);
        else
            rto__fail(msg, st, "%s", why.text);
        if (msg)
            rto__utf8_fix(msg->text, sizeof msg->text);
        return st;
    }
    *out = s;
    return RTO_OK;
}

rto_status rto_scene_load(const char *spec, rto_scene **out, rto_msg *msg)
{
    return rto_scene_load_ex(spec, NULL, out, msg);
}

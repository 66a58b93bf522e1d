/* Reading a stage's bundle back: opening with a kind, manifest counts, arrays checked like GPU dumps, one-line
 * refusals (io/bundle_in.h). */
#include "io/bundle_in.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

rto_status rto__bundle_in_open(rto__bundle_in *in, const char *dir, const char *kind, const char *writer, rto_msg *msg)
{
    in->r = NULL;
    in->dir = dir ? dir : "";
    in->msg = msg;
    if (!dir)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL bundle directory");
    rto_status s = rto_bundle_open(dir, &in->r, msg);
    if (s)
        return s;
    const char *k = rto_bundle_get_str(in->r, "", "kind");
    if (kind && (!k || strcmp(k, kind)))
        return rto__fail(msg, RTO_ERR_PARSE, "%s is not a %s bundle (rtoracle %s)", dir, kind, writer);
    return RTO_OK;
}

void rto__bundle_in_close(rto__bundle_in *in)
{
    rto_bundle_close(in->r);
    in->r = NULL;
}

rto_status rto__bundle_refuse(const rto__bundle_in *in, const char *file, const char *fmt, ...)
{
    char text[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return rto__fail(in->msg, RTO_ERR_PARSE, "%s: %s: %s", in->dir, file, text);
}

rto_status rto__bundle_count(const rto__bundle_in *in, const char *section, const char *key, uint64_t max,
                             size_t *out)
{
    int64_t v = -1;
    if (!rto_bundle_get_int(in->r, section, key, &v) || v < 0 || (uint64_t)v > max)
        return rto__bundle_refuse(in, "manifest.json", "%s.%s is missing or outside 0 .. %" PRIu64, section, key, max);
    *out = (size_t)v;
    return RTO_OK;
}

rto_status rto__bundle_load(const rto__bundle_in *in, const char *name, const rto_npy_desc *want, const char *layout,
                            rto_npy *out)
{
    rto_msg why = {{0}};
    char have[160], need[160];
    rto_status s = rto_bundle_read_name(in->r, name, out, &why);
    if (s)
        return rto__fail(in->msg, s, "%s: %s", in->dir, why.text);
    rto_npy_desc w = *want;
    const int any_rows = want->shape[0] == UINT64_MAX;
    if (any_rows && out->desc.ndim >= 1)
        w.shape[0] = out->desc.shape[0];
    if (rto_npy_desc_equal(&out->desc, &w))
        return RTO_OK;
    /* the layout's name for what has its fields, whatever its shape */
    rto_npy_desc same_fields = out->desc;
    memcpy(same_fields.shape, w.shape, sizeof same_fields.shape);
    same_fields.ndim = w.ndim;
    const char *have_layout = rto_npy_desc_equal(&same_fields, &w) ? layout : NULL;
    rto_npy_desc_text(&w, layout, need, sizeof need);
    if (any_rows) /* "shape (N, 3)", not the count of whatever was found */
        snprintf(need, sizeof need, "dtype <f4, shape (N, 3)");
    return rto__bundle_refuse(in, name, "holds %s; expected %s", rto_npy_desc_text(&out->desc, have_layout, have,
                                                                                   sizeof have), need);
}

const char *rto__bundle_name(rto_bundle_file f, uint32_t index, char name[RTO_BUNDLE_FILE_NAME_MAX])
{
    if (rto_bundle_file_name(f, index, name, RTO_BUNDLE_FILE_NAME_MAX))
        snprintf(name, RTO_BUNDLE_FILE_NAME_MAX, "(bundle file %d)", (int)f); /* unreachable: every name fits */
    return name;
}

bool rto__all_finite(const float *v, size_t n)
{
    for (size_t k = 0; k < n; k++)
        if (!isfinite(v[k]))
            return false;
    return true;
}

int rto_npy_desc_equal(const rto_npy_desc *have, const rto_npy_desc *want)
{
    if (!have || !want || have->dtype != want->dtype || have->ndim != want->ndim)
        return false;
    for (uint32_t i = 0; i < want->ndim && i < RTO_NPY_MAX_DIMS; i++)
        if (have->shape[i] != want->shape[i])
            return false;
    if (want->dtype != RTO_DTYPE_STRUCT)
        return true;
    if (have->nfields != want->nfields)
        return false;
    for (uint32_t i = 0; i < want->nfields && i < RTO_NPY_MAX_FIELDS; i++) {
        const rto_npy_field *a = &have->fields[i], *b = &want->fields[i];
        if (a->type != b->type || a->count != b->count || a->offset != b->offset || strcmp(a->name, b->name))
            return false;
    }
    return true;
}

const char *rto_npy_desc_text(const rto_npy_desc *d, const char *layout, char *buf, size_t cap)
{
    char descr[256];
    int used;
    if (!buf || !cap)
        return buf;
    if (d->dtype == RTO_DTYPE_STRUCT && layout) /* a struct's full descr would fill the line */
        used = snprintf(buf, cap, "%s records, shape (", layout);
    else if (d->dtype == RTO_DTYPE_STRUCT)
        used = snprintf(buf, cap, "%zu-byte records, shape (", rto_npy_itemsize(d));
    else
        used = snprintf(buf, cap, "dtype %s, shape (", rto_npy_descr(d, descr, sizeof descr) ? "?" : descr);
    for (uint32_t i = 0; used >= 0 && (size_t)used < cap && i < d->ndim && i < RTO_NPY_MAX_DIMS; i++)
        used += snprintf(buf + used, cap - (size_t)used, "%s%llu%s", i ? " " : "", (unsigned long long)d->shape[i],
                         d->ndim == 1 || i + 1 < d->ndim ? "," : "");
    if (used >= 0 && (size_t)used < cap)
        snprintf(buf + used, cap - (size_t)used, ")");
    return buf;
}

/* NumPy structured dtypes of the GPU structs of DESIGN.md §5, as written into bundles and accepted from GPU dumps. */
#include "cli.h"

#include <string.h>

static rto_npy_desc record(uint64_t n)
{
    rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_NONE, 1, n, 0, 0);
    d.dtype = RTO_DTYPE_STRUCT;
    return d;
}

static void field(rto_npy_desc *d, const char *name, rto_dtype t, uint32_t count)
{
    rto_npy_field *f = &d->fields[d->nfields];
    memset(f, 0, sizeof *f);
    strncpy(f->name, name, sizeof f->name - 1);
    f->type = t;
    f->count = count;
    f->offset = d->nfields ? d->fields[d->nfields - 1].offset +
                                 (uint32_t)rto_dtype_size(d->fields[d->nfields - 1].type) * d->fields[d->nfields - 1].count
                           : 0;
    d->nfields++;
}

rto_npy_desc layout_desc(layout_kind k, uint64_t n)
{
    rto_npy_desc d = record(n);
    switch (k) {
    case LAYOUT_TLAS_NODE:
        field(&d, "min", RTO_DTYPE_F32, 3);
        field(&d, "item", RTO_DTYPE_U32, 1);
        field(&d, "max", RTO_DTYPE_F32, 3);
        field(&d, "pad", RTO_DTYPE_U32, 1);
        break;
    case LAYOUT_BVH_NODE:
        field(&d, "lmin", RTO_DTYPE_F32, 3);
        field(&d, "left", RTO_DTYPE_U32, 1);
        field(&d, "lmax", RTO_DTYPE_F32, 3);
        field(&d, "right", RTO_DTYPE_U32, 1);
        field(&d, "rmin", RTO_DTYPE_F32, 3);
        field(&d, "parent", RTO_DTYPE_U32, 1);
        field(&d, "rmax", RTO_DTYPE_F32, 3);
        field(&d, "pad", RTO_DTYPE_U32, 1);
        break;
    case LAYOUT_AABB:
        field(&d, "min", RTO_DTYPE_F32, 3);
        field(&d, "max", RTO_DTYPE_F32, 3);
        break;
    case LAYOUT_INSTANCE:
        field(&d, "objToWorld", RTO_DTYPE_F32, 12);
        field(&d, "worldToObj", RTO_DTYPE_F32, 12);
        field(&d, "blas", RTO_DTYPE_U32, 1);
        field(&d, "customIndex", RTO_DTYPE_U32, 1);
        field(&d, "mask", RTO_DTYPE_U32, 1);
        field(&d, "sbtOffset", RTO_DTYPE_U32, 1);
        field(&d, "flags", RTO_DTYPE_U32, 1);
        field(&d, "pad", RTO_DTYPE_U32, 3);
        break;
    }
    return d;
}

const char *layout_name(layout_kind k)
{
    static const char *names[] = {"TlasNode", "BlasNode", "Aabb", "InstanceRecord"};
    return names[k];
}

size_t layout_size(layout_kind k)
{
    rto_npy_desc d = layout_desc(k, 0);
    return rto_npy_itemsize(&d);
}

/* A GPU dump is accepted as the structured dtype itself (field names may differ: only types, counts and offsets
 * must match), a 2-D uint32/float32 array of (count, words), or a flat uint32/float32 buffer of count * words. */
rto_status layout_accept(layout_kind k, const rto_npy *npy, size_t *count, rto_msg *msg)
{
    const size_t rec = layout_size(k), words = rec / 4;
    const rto_npy_desc *d = &npy->desc, want = layout_desc(k, 0);
    if (d->dtype == RTO_DTYPE_STRUCT) {
        int same = d->ndim == 1 && d->nfields == want.nfields;
        for (uint32_t i = 0; same && i < want.nfields; i++)
            same = d->fields[i].type == want.fields[i].type && d->fields[i].count == want.fields[i].count &&
                   d->fields[i].offset == want.fields[i].offset;
        if (!same)
            return cli_error(msg, RTO_ERR_PARSE, "a structured dump must be 1-D with the %s layout (%zu bytes)",
                            layout_name(k), rec);
        *count = (size_t)d->shape[0];
        return RTO_OK;
    }
    if (d->dtype != RTO_DTYPE_U32 && d->dtype != RTO_DTYPE_F32)
        return cli_error(msg, RTO_ERR_PARSE, "expected %s records, a (count, %zu) or a flat uint32/float32 array",
                        layout_name(k), words);
    if (d->ndim == 2 && d->shape[1] == words) {
        *count = (size_t)d->shape[0];
        return RTO_OK;
    }
    if (d->ndim == 1 && d->shape[0] % words == 0) {
        *count = (size_t)(d->shape[0] / words);
        return RTO_OK;
    }
    return cli_error(msg, RTO_ERR_PARSE, "a raw %s dump must have shape (count, %zu) or a multiple of %zu words",
                    layout_name(k), words, words);
}

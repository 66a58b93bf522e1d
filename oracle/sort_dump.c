/* A GPU's sort dump as check-sort reads it: the sorted buffer (keys, or {key, value} records), the values carried
 * with the keys and the checkpoint passes, each checked against the input's format and the others' sizes. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

/* Splits a structured {key, value} GPU dump into separate key and value arrays. */
static int split_pairs(rto_npy *gpu, rto_npy *values, const char *path)
{
    const rto_npy_desc *d = &gpu->desc;
    const rto_npy_field *kf = NULL, *vf = NULL;
    for (uint32_t i = 0; i < d->nfields; i++) {
        if (!strcmp(d->fields[i].name, "key"))
            kf = &d->fields[i];
        if (!strcmp(d->fields[i].name, "value"))
            vf = &d->fields[i];
    }
    if (d->ndim != 1 || !kf || !vf || kf->count != 1 || vf->count != 1 || vf->type != RTO_DTYPE_U32 ||
        (kf->type != RTO_DTYPE_U32 && kf->type != RTO_DTYPE_U64))
        return cli_fail("check-sort", "%s: a structured GPU dump must be 1-D with fields key (<u4 or <u8) and value "
                        "(<u4)", path);
    size_t n = (size_t)d->shape[0], rec = rto_npy_itemsize(d), ksz = rto_dtype_size(kf->type);
    unsigned char *keys = malloc(n ? n * ksz : 1), *vals = malloc(n ? n * 4 : 1);
    if (!keys || !vals) {
        free(keys);
        free(vals);
        return cli_fail("check-sort", "out of memory");
    }
    for (size_t i = 0; i < n; i++) {
        memcpy(keys + i * ksz, (unsigned char *)gpu->data + i * rec + kf->offset, ksz);
        memcpy(vals + i * 4, (unsigned char *)gpu->data + i * rec + vf->offset, 4);
    }
    free(gpu->data);
    gpu->data = keys;
    gpu->nbytes = n * ksz;
    gpu->desc = rto_npy_desc_keys(kf->type == RTO_DTYPE_U32 ? RTO_KEY_U32 : RTO_KEY_U64, n);
    values->data = vals;
    values->nbytes = n * 4;
    values->desc = rto_npy_desc_array(RTO_DTYPE_U32, 1, n, 0, 0);
    return EXIT_PASS;
}

static int load(const char *path, rto_npy *out, const char *what)
{
    rto_msg msg = {{0}};
    if (rto_npy_read(path, out, &msg))
        return cli_fail("check-sort", "%s %s: %s", what, path, msg.text);
    return EXIT_PASS;
}

void cli_sort_dump_free(cli_sort_dump *dump)
{
    rto_npy_free(&dump->gpu);
    rto_npy_free(&dump->values);
    rto_npy_free(&dump->passes);
}

int cli_sort_dump_load(const char *gpu, const char *values, const char *passes, cli_sort_dump *l,
                       rto_sort_check_desc *d)
{
    rto_msg msg = {{0}};
    int rc = load(gpu, &l->gpu, "--gpu");
    if (rc)
        return rc;
    if (l->gpu.desc.dtype == RTO_DTYPE_STRUCT) {
        if (values)
            return cli_fail("check-sort", "--gpu-values given, but --gpu %s already carries values", gpu);
        if ((rc = split_pairs(&l->gpu, &l->values, gpu)))
            return rc;
    } else if (values && (rc = load(values, &l->values, "--gpu-values"))) {
        return rc;
    }
    rto_key_format gf;
    size_t gn;
    if (rto_npy_as_keys(&l->gpu, &gf, &gn, &msg))
        return cli_fail("check-sort", "--gpu %s: %s", gpu, msg.text);
    if (gf != d->format)
        return cli_fail("check-sort", "--gpu %s holds %s keys but the input holds %s keys", gpu,
                        gf == RTO_KEY_U32 ? "uint32" : "uint64", d->format == RTO_KEY_U32 ? "uint32" : "uint64");
    d->gpu_keys = l->gpu.data;
    d->gpu_n = gn;
    if (l->values.data) {
        if (l->values.desc.dtype != RTO_DTYPE_U32 || l->values.desc.ndim != 1 || l->values.desc.shape[0] != gn)
            return cli_fail("check-sort", "GPU values must be a 1-D uint32 array of %zu entries (one per GPU slot)",
                            gn);
        d->gpu_values = l->values.data;
    }
    if (!passes)
        return EXIT_PASS;
    if ((rc = load(passes, &l->passes, "--gpu-passes")))
        return rc;
    rto_dtype want = d->format == RTO_KEY_U32 ? RTO_DTYPE_U32 : RTO_DTYPE_U64;
    if (l->passes.desc.dtype != want || l->passes.desc.ndim != 2)
        return cli_fail("check-sort", "--gpu-passes %s: expected a 2-D %s array (passes x slots)", passes,
                        want == RTO_DTYPE_U32 ? "uint32" : "uint64");
    if (l->passes.desc.shape[0] > UINT32_MAX)
        return cli_fail("check-sort", "--gpu-passes %s: too many passes", passes);
    d->gpu_passes = l->passes.data;
    d->gpu_pass_count = (uint32_t)l->passes.desc.shape[0];
    d->gpu_pass_len = (size_t)l->passes.desc.shape[1];
    return EXIT_PASS;
}

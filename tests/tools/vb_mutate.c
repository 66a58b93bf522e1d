/* Test tool: makes a "GPU dump" of a vbuffer bundle (rtoracle vbuffer) by copying the planes, mask and image a GPU
 * harness writes, and injects one named fault, so that the command-line tests can assert that check-vbuffer names
 * that fault where it was made. Knows nothing of the validator: it edits arrays through the public API and prints
 * where it made the change (x= y= sample= words).
 *
 *   vb_mutate MUTATION BUNDLE GPUDIR      GPUDIR must not exist
 *
 *   copy          the dump as written                       u32       visibility and mask as uint32 words
 *   flat          every plane as a flat array               bits      every binary16 plane as uint16 bit patterns
 *   unorm24       depth as depth24plus stores it: vb_depth_unorm24 / (2^24 - 1)
 *   coverage      the first certain covered sample (admissible set of one triangle) made background
 *   id            the same sample's primitive with its lowest bit flipped (a neighbour in the mesh, or past its end)
 *   instance      the same sample's instance with its lowest bit flipped
 *   bary          the same sample's b1 + 0.05
 *   normal-sign   the first covered sample whose octahedral x is not 0: x negated
 *   deriv         the first covered sample whose ddx b1 is over 1e-3 in magnitude: negated
 *   depth         the first certain covered sample's depth + 1e-3
 *   depth-step    every certain covered sample's depth one unorm24 step up: (round(z (2^24 - 1)) + 1) / (2^24 - 1)
 *   mask          the first interior pixel whose sample 0 is covered, marked an edge   -> x= y=
 *   image         the middle pixel's red + 0.25                                          -> x= y=
 *   no-mask       vb_edge_mask.npy and vb_image.npy left out
 *   transposed    vb_visibility.npy shaped (W, H, S, 4): the right size, the wrong shape
 */
#include "rtoracle.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *const files[] = {"vb_visibility.npy", "vb_barycentric.npy", "vb_normal.npy", "vb_derivatives.npy",
                                    "vb_depth.npy",      "vb_edge_mask.npy",   "vb_image.npy"};
enum { VIS, BARY, NORMAL, DERIV, DEPTH, MASK, IMAGE, NFILES };

static rto_npy a[NFILES], u24, offsets;

static int die(const char *m, const char *detail)
{
    fprintf(stderr, "vb_mutate: %s%s%s\n", m, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

static void load(const char *dir, const char *name, rto_npy *out)
{
    char path[4096];
    rto_msg msg = {{0}};
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (rto_npy_read(path, out, &msg))
        die(path, msg.text);
}

static void save(const char *dir, const char *name, const rto_npy_desc *d, const void *data)
{
    char path[4096];
    rto_msg msg = {{0}};
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (rto_npy_write(path, d, data, &msg))
        die(path, msg.text);
}

static uint64_t elems(const rto_npy_desc *d)
{
    uint64_t n = 1;
    for (uint32_t k = 0; k < d->ndim; k++)
        n *= d->shape[k];
    return n;
}

int main(int argc, char **argv)
{
    if (argc != 4)
        die("usage: vb_mutate MUTATION BUNDLE GPUDIR", NULL);
    const char *m = argv[1], *bundle = argv[2], *out = argv[3];
    for (int k = 0; k < NFILES; k++)
        load(bundle, files[k], &a[k]);
    load(bundle, "vb_depth_unorm24.npy", &u24);
    load(bundle, "vb_admissible_offsets.npy", &offsets);
    const uint32_t H = (uint32_t)a[VIS].desc.shape[0], W = (uint32_t)a[VIS].desc.shape[1];
    const uint32_t S = (uint32_t)a[VIS].desc.shape[2];
    const size_t n = (size_t)H * W * S;
    uint16_t *vis = a[VIS].data, *bary = a[BARY].data, *nrm = a[NORMAL].data, *der = a[DERIV].data;
    uint16_t *img = a[IMAGE].data;
    float *depth = a[DEPTH].data;
    const uint32_t *off = offsets.data, *u = u24.data;
    uint8_t *mask = a[MASK].data;
    /* the first covered sample with an admissible set of one member */
    size_t certain = n;
    for (size_t k = 0; k < n && certain == n; k++)
        if (vis[4 * k] != 0xffff && off[k + 1] - off[k] == 1)
            certain = k;
    if (certain == n)
        die("no certain covered sample", bundle);
    size_t at = certain;
    int print_sample = 1, skip_mask = 0;
    if (!strcmp(m, "coverage")) {
        for (int c = 0; c < 4; c++)
            vis[4 * at + c] = 0xffff;
    } else if (!strcmp(m, "id")) {
        vis[4 * at] ^= 1u; /* a neighbour of the primitive: still in the mesh */
    } else if (!strcmp(m, "instance")) {
        vis[4 * at + 2] ^= 1u;
    } else if (!strcmp(m, "bary")) {
        bary[2 * at] = rto_f16_from_f32(rto_f16_to_f32(bary[2 * at]) + 0.05f);
    } else if (!strcmp(m, "normal-sign")) {
        for (at = 0; at < n && (vis[4 * at] == 0xffff || (nrm[4 * at] & 0x7fffu) == 0); at++)
            ;
        if (at == n)
            die("no covered sample with a non-zero octahedral x", bundle);
        nrm[4 * at] ^= 0x8000u;
    } else if (!strcmp(m, "deriv")) {
        for (at = 0; at < n && (vis[4 * at] == 0xffff || fabsf(rto_f16_to_f32(der[4 * at])) <= 1e-3f); at++)
            ;
        if (at == n)
            die("no covered sample with |ddx b1| over 1e-3", bundle);
        der[4 * at] ^= 0x8000u;
    } else if (!strcmp(m, "depth")) {
        depth[at] += 1e-3f;
    } else if (!strcmp(m, "depth-step")) {
        for (size_t k = 0; k < n; k++)
            if (vis[4 * k] != 0xffff && off[k + 1] - off[k] == 1)
                depth[k] = (float)((double)(u[k] + 1) / 16777215.0);
    } else if (!strcmp(m, "unorm24")) {
        for (size_t k = 0; k < n; k++)
            depth[k] = (float)((double)u[k] / 16777215.0);
        print_sample = 0;
    } else if (!strcmp(m, "mask")) {
        size_t p = 0;
        for (; p < (size_t)H * W && (mask[p] || vis[4 * p * S] == 0xffff); p++)
            ;
        if (p == (size_t)H * W)
            die("no interior covered pixel", bundle);
        mask[p] = 1;
        printf("x=%zu y=%zu\n", p % W, p / W);
        print_sample = 0;
    } else if (!strcmp(m, "image")) {
        const size_t p = (size_t)(H / 2) * W + W / 2;
        img[4 * p] = rto_f16_from_f32(rto_f16_to_f32(img[4 * p]) + 0.25f);
        printf("x=%zu y=%zu\n", p % W, p / W);
        print_sample = 0;
    } else if (!strcmp(m, "no-mask")) {
        skip_mask = 1;
        print_sample = 0;
    } else if (!strcmp(m, "transposed")) {
        a[VIS].desc.shape[0] = W;
        a[VIS].desc.shape[1] = H;
        print_sample = 0;
    } else if (strcmp(m, "copy") && strcmp(m, "u32") && strcmp(m, "flat") && strcmp(m, "bits")) {
        die("unknown mutation", m);
    } else {
        print_sample = 0;
    }
    if (print_sample)
        printf("x=%zu y=%zu sample=%zu\n", at / S % W, at / S / W, at % S);
    if (mkdir(out, 0777) != 0)
        die("cannot create", out);
    for (int k = 0; k < NFILES; k++) {
        if (skip_mask && (k == MASK || k == IMAGE))
            continue;
        rto_npy_desc d = a[k].desc;
        const void *data = a[k].data;
        void *tmp = NULL;
        const uint64_t e = elems(&d);
        if (!strcmp(m, "flat")) {
            d.ndim = 1;
            d.shape[0] = e;
        }
        if (!strcmp(m, "bits") && d.dtype == RTO_DTYPE_F16)
            d.dtype = RTO_DTYPE_U16;
        if (!strcmp(m, "u32") && (k == VIS || k == MASK)) {
            uint32_t *w = malloc(e * sizeof *w);
            for (uint64_t i = 0; w && i < e; i++)
                w[i] = k == VIS ? ((const uint16_t *)data)[i] : ((const uint8_t *)data)[i];
            d.dtype = RTO_DTYPE_U32;
            data = tmp = w;
        }
        save(out, files[k], &d, data);
        free(tmp);
    }
    return 0;
}

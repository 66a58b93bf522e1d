/* Test tool: rewrites a splat dump's arrays in the other shapes a GPU harness may write, or with a resolve rounding
 * toward zero. Knows nothing of the validators (public npy API only).
 *
 *   volume_dump flat FILE           the same values as a flat array
 *   volume_dump as-u16 FILE         binary16 values as their uint16 bit patterns
 *   volume_dump rgba FILE           an (NZ, NY, NX) binary16 density as (NZ, NY, NX, 4): density, 0, 0, 1
 *   volume_dump rtz DIR SCALE       DIR/volume_f16.npy rewritten from DIR/volume_u32.npy: f32(u) / SCALE stored as
 *                                   binary16 rounded toward zero (computed from the binary32's bits) */
#include "rtoracle.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int die(const char *m)
{
    fprintf(stderr, "volume_dump: %s\n", m);
    return 2;
}

/* binary16 bits of a non-negative binary32, rounded toward zero: the exponent rebased, the significand cut. */
static uint16_t f16_rtz(float f)
{
    uint32_t b;
    memcpy(&b, &f, 4);
    const int e = (int)(b >> 23 & 0xFF) - 127;
    const uint32_t m = b & 0x7FFFFF;
    if (e > 15)
        return 0x7BFF;
    if (e >= -14)
        return (uint16_t)((uint32_t)(e + 15) << 10 | m >> 13);
    if (e < -25)
        return 0;
    return (uint16_t)((m | 0x800000) >> (-e - 1)); /* subnormal: (1.m) 2^e / 2^-24 */
}

int main(int argc, char **argv)
{
    if (argc < 3)
        return die("usage: volume_dump flat|as-u16|rgba FILE | rtz DIR SCALE");
    const char *op = argv[1];
    char path[4096];
    rto_npy a = {0};
    rto_msg msg = {{0}};
    if (!strcmp(op, "rtz")) {
        if (argc != 4)
            return die("rtz DIR SCALE");
        snprintf(path, sizeof path, "%s/volume_u32.npy", argv[2]);
        if (rto_npy_read(path, &a, &msg))
            return die(msg.text);
        const float scale = strtof(argv[3], NULL);
        const size_t n = a.nbytes / 4;
        uint16_t *h = malloc(n * 2 + 2);
        for (size_t i = 0; i < n; i++)
            h[i] = f16_rtz((float)((const uint32_t *)a.data)[i] / scale);
        rto_npy_desc d = a.desc;
        d.dtype = RTO_DTYPE_F16;
        snprintf(path, sizeof path, "%s/volume_f16.npy", argv[2]);
        int rc = rto_npy_write(path, &d, h, &msg) ? die(msg.text) : 0;
        free(h);
        rto_npy_free(&a);
        return rc;
    }
    const char *file = argv[2];
    if (rto_npy_read(file, &a, &msg))
        return die(msg.text);
    size_t elems = 1;
    for (uint32_t k = 0; k < a.desc.ndim; k++)
        elems *= a.desc.shape[k];
    int rc = 0;
    if (!strcmp(op, "flat")) {
        a.desc.ndim = 1;
        a.desc.shape[0] = elems;
        rc = rto_npy_write(file, &a.desc, a.data, &msg) ? die(msg.text) : 0;
    } else if (!strcmp(op, "as-u16")) {
        a.desc.dtype = RTO_DTYPE_U16;
        rc = rto_npy_write(file, &a.desc, a.data, &msg) ? die(msg.text) : 0;
    } else if (!strcmp(op, "rgba") && a.desc.ndim == 3) {
        uint16_t *h = calloc(elems * 4 + 4, 2);
        for (size_t i = 0; i < elems; i++) {
            h[4 * i] = ((const uint16_t *)a.data)[i];
            h[4 * i + 3] = 0x3C00;
        }
        a.desc.ndim = 4;
        a.desc.shape[3] = 4;
        rc = rto_npy_write(file, &a.desc, h, &msg) ? die(msg.text) : 0;
        free(h);
    } else {
        rc = die("unknown operation");
    }
    rto_npy_free(&a);
    return rc;
}

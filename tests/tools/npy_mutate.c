/* Test tool: injects one named fault into a correct .npy output and prints where it put it, so the command-line
 * tests can assert that check-sort names that fault at that slot. Knows nothing of the validator.
 *
 *   npy_mutate swap-adjacent|dup-neighbour|drop-sentinel|flip-bit  IN OUT [N]   -> prints the slot
 *   npy_mutate swap-values PAIRS OUT [N]   ({key, value} records)               -> prints the slot
 *   npy_mutate corrupt-pass IN OUT         (2-D passes x slots)                 -> prints "pass slot"
 *   npy_mutate zip KEYS VALUES OUT         builds a {key, value} record file
 * N is the number of real keys (default: the array length); mutations stay inside the real range. */
#include "rtoracle.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t get(const rto_npy *a, size_t i, size_t stride, size_t ksz)
{
    uint64_t v = 0;
    memcpy(&v, (const unsigned char *)a->data + i * stride, ksz);
    return v;
}

static void put(rto_npy *a, size_t i, size_t stride, size_t ksz, uint64_t v)
{
    memcpy((unsigned char *)a->data + i * stride, &v, ksz);
}

static int die(const char *m)
{
    fprintf(stderr, "npy_mutate: %s\n", m);
    return 2;
}

int main(int argc, char **argv)
{
    if (argc < 4)
        return die("usage: npy_mutate MUTATION IN OUT [N]");
    const char *mut = argv[1];
    rto_msg msg = {{0}};
    rto_npy a = {0};
    if (rto_npy_read(argv[2], &a, &msg))
        return die(msg.text);
    if (!strcmp(mut, "zip")) {
        rto_npy v = {0};
        if (rto_npy_read(argv[3], &v, &msg) || argc < 5)
            return die("zip KEYS VALUES OUT");
        size_t n = (size_t)a.desc.shape[0], ksz = rto_dtype_size(a.desc.dtype);
        rto_npy_desc d = rto_npy_desc_array(RTO_DTYPE_NONE, 1, n, 0, 0);
        d.dtype = RTO_DTYPE_STRUCT;
        d.nfields = 2;
        d.fields[0] = (rto_npy_field){"key", a.desc.dtype, 1, 0};
        d.fields[1] = (rto_npy_field){"value", RTO_DTYPE_U32, 1, (uint32_t)ksz};
        unsigned char *rec = malloc(n * (ksz + 4) + 1);
        for (size_t i = 0; i < n; i++) {
            memcpy(rec + i * (ksz + 4), (unsigned char *)a.data + i * ksz, ksz);
            memcpy(rec + i * (ksz + 4) + ksz, (unsigned char *)v.data + i * 4, 4);
        }
        rto_status s = rto_npy_write(argv[4], &d, rec, &msg);
        free(rec);
        rto_npy_free(&a);
        rto_npy_free(&v);
        return s ? die(msg.text) : 0;
    }
    size_t len = (size_t)a.desc.shape[0], stride, ksz;
    if (a.desc.dtype == RTO_DTYPE_STRUCT) {
        stride = rto_npy_itemsize(&a.desc);
        ksz = rto_dtype_size(a.desc.fields[0].type);
    } else {
        stride = ksz = rto_dtype_size(a.desc.dtype);
    }
    size_t n = argc > 4 ? (size_t)strtoull(argv[4], NULL, 10) : len;
    uint64_t sentinel = ksz == 4 ? UINT32_MAX : UINT64_MAX;
    size_t slot = SIZE_MAX;
    if (!strcmp(mut, "corrupt-pass")) {
        size_t passes = len, width = (size_t)a.desc.shape[1], p = passes / 2, s = width / 2;
        put(&a, p * width + s, stride, ksz, get(&a, p * width + s, stride, ksz) ^ 0x10);
        printf("%zu %zu\n", p, s);
    } else if (!strcmp(mut, "flip-bit")) {
        slot = n / 2;
        for (unsigned bit = 0; bit < ksz * 8; bit++) {
            uint64_t v = get(&a, slot, stride, ksz) ^ ((uint64_t)1 << bit);
            int found = v == sentinel;
            for (size_t i = 0; i < n && !found; i++)
                found = get(&a, i, stride, ksz) == v;
            if (!found) {
                put(&a, slot, stride, ksz, v);
                break;
            }
        }
        printf("%zu\n", slot);
    } else {
        int equal = !strcmp(mut, "swap-values");
        for (size_t i = n / 2; i + 1 < n && slot == SIZE_MAX; i++)
            if ((get(&a, i, stride, ksz) == get(&a, i + 1, stride, ksz)) == equal)
                slot = i;
        if (slot == SIZE_MAX)
            return die("no suitable slot for this mutation");
        unsigned char *base = a.data, tmp[64];
        size_t i = slot;
        if (!strcmp(mut, "swap-adjacent") || equal) {
            if (equal) { /* swap only the value field */
                size_t off = a.desc.fields[1].offset;
                memcpy(tmp, base + i * stride + off, 4);
                memcpy(base + i * stride + off, base + (i + 1) * stride + off, 4);
                memcpy(base + (i + 1) * stride + off, tmp, 4);
            } else {
                memcpy(tmp, base + i * stride, stride);
                memcpy(base + i * stride, base + (i + 1) * stride, stride);
                memcpy(base + (i + 1) * stride, tmp, stride);
            }
        } else if (!strcmp(mut, "dup-neighbour")) {
            memcpy(base + (i + 1) * stride, base + i * stride, stride);
            slot = i + 1;
        } else if (!strcmp(mut, "drop-sentinel")) {
            memmove(base + i * stride, base + (i + 1) * stride, (len - i - 1) * stride);
            put(&a, len - 1, stride, ksz, sentinel);
        } else {
            return die("unknown mutation");
        }
        printf("%zu\n", slot);
    }
    if (rto_npy_write(argv[3], &a.desc, a.data, &msg))
        return die(msg.text);
    rto_npy_free(&a);
    return 0;
}

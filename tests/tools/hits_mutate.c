/* Test tool: injects one named fault into a correct hits.npy (HitRecord records, one per ray) and prints the ray it
 * changed, so the command-line tests can assert that check-hits names that fault at that ray. Knows nothing of the
 * validator or the scene: it picks the first hit (or miss) at or after the middle of the array.
 *
 *   hits_mutate t|bary-swap|hit-to-miss|miss-to-hit|flag-2|prim|instance|oob-instance|custom-index|hit-group|
 *               row-major|truncate  IN OUT          -> prints the ray
 *   hits_mutate words|flat  IN OUT                  the same records as a (n, 24) float32 array / flat uint32 words
 *
 * prim takes primId ^ 2 and instance instanceId ^ 1 (another face / the neighbouring instance of an rtstress scene);
 * row-major writes objToWorld's 12 values in row-major order into the 4 columns, as a GPU that forgot the mat4x3
 * layout would. */
#include "rtoracle.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int die(const char *m)
{
    fprintf(stderr, "hits_mutate: %s\n", m);
    return 2;
}

/* The first record at or after the middle with the given miss flag (and, for bary-swap, distinct barycentrics). */
static size_t pick(const rto_hit_record *h, size_t n, uint32_t miss, int distinct_bary)
{
    for (size_t k = 0; k < n; k++) {
        const size_t i = (n / 2 + k) % n;
        if (h[i].miss_flag == miss && (!distinct_bary || fabsf(h[i].bary[0] - h[i].bary[1]) > 0.01f))
            return i;
    }
    return SIZE_MAX;
}

int main(int argc, char **argv)
{
    if (argc != 4)
        return die("usage: hits_mutate MUTATION IN OUT");
    const char *mut = argv[1];
    rto_msg msg = {{0}};
    rto_npy a = {0};
    size_t n = 0;
    if (rto_npy_read(argv[2], &a, &msg) || rto_layout_accept(RTO_LAYOUT_HIT_RECORD, &a, &n, &msg))
        return die(msg.text);
    rto_hit_record *h = a.data;
    rto_npy_desc d = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, n);
    size_t i = SIZE_MAX;
    if (!strcmp(mut, "words") || !strcmp(mut, "flat")) {
        d = !strcmp(mut, "words") ? rto_npy_desc_array(RTO_DTYPE_F32, 2, n, 24, 0)
                                  : rto_npy_desc_array(RTO_DTYPE_U32, 1, 24 * n, 0, 0);
    } else if (!strcmp(mut, "truncate")) {
        if (!n)
            return die("nothing to truncate");
        d = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, n - 1);
        i = n - 1;
    } else {
        const int on_miss = !strcmp(mut, "miss-to-hit");
        i = pick(h, n, on_miss ? 1 : 0, !strcmp(mut, "bary-swap"));
        if (i == SIZE_MAX)
            return die(on_miss ? "no miss to mutate" : "no hit to mutate");
        rto_hit_record *r = &h[i];
        if (!strcmp(mut, "t")) {
            r->t *= 1.001f;
        } else if (!strcmp(mut, "bary-swap")) {
            const float u = r->bary[0];
            r->bary[0] = r->bary[1];
            r->bary[1] = u;
        } else if (!strcmp(mut, "hit-to-miss") || !strcmp(mut, "miss-to-hit")) {
            r->miss_flag ^= 1u;
        } else if (!strcmp(mut, "flag-2")) {
            r->miss_flag = 2;
        } else if (!strcmp(mut, "prim")) {
            r->prim_id ^= 2u;
        } else if (!strcmp(mut, "instance")) {
            r->instance_id ^= 1u;
        } else if (!strcmp(mut, "oob-instance")) {
            r->instance_id = 1000000;
        } else if (!strcmp(mut, "custom-index")) {
            r->custom_index += 1;
        } else if (!strcmp(mut, "hit-group")) {
            r->hit_group += 1;
        } else if (!strcmp(mut, "row-major")) {
            float m[12];
            for (int row = 0; row < 3; row++)
                for (int c = 0; c < 4; c++)
                    m[4 * row + c] = r->obj_to_world[c][row];
            for (int c = 0; c < 4; c++)
                for (int row = 0; row < 3; row++)
                    r->obj_to_world[c][row] = m[3 * c + row];
        } else {
            return die("unknown mutation");
        }
    }
    if (rto_npy_write(argv[3], &d, h, &msg))
        return die(msg.text);
    if (i != SIZE_MAX)
        printf("%zu\n", i);
    rto_npy_free(&a);
    return 0;
}

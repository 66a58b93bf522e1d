/* Test tool: makes a "GPU dump" of a frame bundle (rtoracle render) by copying the files a GPU harness writes, and
 * injects one named fault into it, so that the command-line tests can assert that check-frame names that fault at
 * that stage and bounce. Knows nothing of the validator: it edits arrays through the public API and prints where it
 * made the change (key=value words) for the test to compare with the report.
 *
 *   frame_mutate MUTATION BUNDLE GPUDIR [D]      GPUDIR must not exist; D is a bounce (queue) index
 *
 *   copy                 the dump as written (every file a GPU harness writes, nothing changed)
 *   shuffle D            queue D (rays, hits, payloads together) in a seeded random order
 *   missing D            the middle ray of queue D (and its hit and payload) removed     -> ray= pixel=
 *   duplicate D          the middle ray of queue D appended once more                    -> ray= pixel=
 *   ray-dir D            the middle ray of queue D with dir.x + 0.01                     -> ray= pixel=
 *   payload D            the middle ray's first payload word + 1 (as a float)            -> ray= pixel=
 *   payload-small D      the same word moved by half the accum tolerance (1e-4 |e| + 1e-6) -> ray= pixel=
 *   prim D               the first hit at or after the middle of queue D: primId ^ 2     -> ray= pixel=
 *   hit-uv D             the first hit at or after the middle with |u - v| > 0.01: u and v swapped
 *   hit-custom D / hit-group D / hit-transform D   the same hit: customIndex + 1 / hitGroup + 3 / objToWorld's
 *                        column 3, row 1 (the translation's y) + 1                      -> ray= pixel=
 *   hit-tmin D           the same hit at t = tMin - 1 - |tMin| (before the ray starts)   -> ray= pixel=
 *   emit D               emit_counts[D] + 1
 *   indirect D           indirect_args[D][0] + 1
 *   accum-big / accum-small   the first comparable pixel at or after the middle, red channel moved by 10 / 0.5
 *                        times the §9 accum tolerance (1e-4 |e| + 1e-6)                  -> pixel= x= y=
 *   image-shift          image.png moved right by one pixel (column 0 kept)
 *   image-pixels N       every channel of image.png moved by 1 (up, or down from 255), and in the first N
 *                        comparable pixels at or after the middle red by 2 instead             -> pixel= x= y=
 *   accum-exr            accum.npy replaced by accum.exr (RGBA float)
 *   words                every queue, hit and counter file as raw (n, words) uint32 / flat float32 arrays
 *   full                 every queue and hit file as the whole GPU buffer: 2 W H records, garbage after the queue
 *   store                every payload file as the whole payload store: 2 W H rows, row = payloadSlot
 *   not-comparable       every pixel the bundle marks not comparable gets accum + 1 and a different image
 *                        colour, and the queues from the first that dropped rays on are reversed, with their first
 *                        ray moved                                                       -> pixels= queue=
 */
#include "rtoracle.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static _Noreturn void die(const char *m)
{
    fprintf(stderr, "frame_mutate: %s\n", m);
    exit(2);
}

static char *path_of(const char *dir, const char *name)
{
    static char buf[4][4096];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", dir, name);
    return buf[k];
}

static const char *fname(rto_bundle_file f, uint32_t d)
{
    static char buf[4][RTO_BUNDLE_FILE_NAME_MAX];
    static int k;
    k = (k + 1) % 4;
    if (rto_bundle_file_name(f, d, buf[k], sizeof buf[k]))
        die("file name");
    return buf[k];
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void load(const char *path, rto_npy *a)
{
    rto_msg msg = {{0}};
    if (rto_npy_read(path, a, &msg))
        die(msg.text);
}

static void save(const char *path, const rto_npy_desc *d, const void *data)
{
    rto_msg msg = {{0}};
    if (rto_npy_write(path, d, data, &msg))
        die(msg.text);
}

static void copy_file(const char *from, const char *to)
{
    FILE *in = fopen(from, "rb"), *out = in ? fopen(to, "wb") : NULL;
    if (!in || !out)
        die("cannot copy a file");
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        if (fwrite(buf, 1, n, out) != n)
            die("cannot write a file");
    fclose(in);
    if (fclose(out))
        die("cannot write a file");
}

/* The frame's shape, from its arrays (not from the manifest: the tool reads what a harness would have). */
static uint32_t W, H, D;

/* A queue file set: rays, hits and payloads of queue d, edited together. */
typedef struct queue {
    rto_npy rays, hits, pay;
    int has_hits, has_pay;
    size_t n;
} queue;

static void queue_load(const char *dir, uint32_t d, queue *q)
{
    memset(q, 0, sizeof *q);
    if (!exists(path_of(dir, fname(RTO_FILE_BOUNCE_RAYS, d))))
        die("the bundle keeps no rays of that queue");
    load(path_of(dir, fname(RTO_FILE_BOUNCE_RAYS, d)), &q->rays);
    q->n = (size_t)q->rays.desc.shape[0];
    q->has_hits = exists(path_of(dir, fname(RTO_FILE_BOUNCE_HITS, d)));
    q->has_pay = exists(path_of(dir, fname(RTO_FILE_BOUNCE_PAYLOADS, d)));
    if (q->has_hits)
        load(path_of(dir, fname(RTO_FILE_BOUNCE_HITS, d)), &q->hits);
    if (q->has_pay)
        load(path_of(dir, fname(RTO_FILE_BOUNCE_PAYLOADS, d)), &q->pay);
}

/* Rewrites queue d with its rows in the order given by perm (m entries: indices into the old rows). */
static void queue_save(const char *dir, uint32_t d, queue *q, const size_t *perm, size_t m)
{
    const size_t pw = q->has_pay ? (size_t)q->pay.desc.shape[1] : 0;
    rto_wf_ray *r = calloc(m + 1, sizeof *r);
    rto_hit_record *h = calloc(m + 1, sizeof *h);
    uint32_t *p = calloc((m + 1) * (pw + 1), sizeof *p);
    if (!r || !h || !p)
        die("out of memory");
    for (size_t i = 0; i < m; i++) {
        r[i] = ((const rto_wf_ray *)q->rays.data)[perm[i]];
        if (q->has_hits)
            h[i] = ((const rto_hit_record *)q->hits.data)[perm[i]];
        if (pw)
            memcpy(p + i * pw, (const uint32_t *)q->pay.data + perm[i] * pw, pw * 4);
    }
    rto_npy_desc dr = rto_layout_desc(RTO_LAYOUT_WF_RAY, m);
    save(path_of(dir, fname(RTO_FILE_BOUNCE_RAYS, d)), &dr, r);
    if (q->has_hits) {
        rto_npy_desc dh = rto_layout_desc(RTO_LAYOUT_HIT_RECORD, m);
        save(path_of(dir, fname(RTO_FILE_BOUNCE_HITS, d)), &dh, h);
    }
    if (q->has_pay) {
        rto_npy_desc dp = rto_npy_desc_array(RTO_DTYPE_U32, 2, m, pw, 0);
        save(path_of(dir, fname(RTO_FILE_BOUNCE_PAYLOADS, d)), &dp, p);
    }
    free(r);
    free(h);
    free(p);
}

static void queue_free(queue *q)
{
    rto_npy_free(&q->rays);
    rto_npy_free(&q->hits);
    rto_npy_free(&q->pay);
}

static size_t *identity(size_t n, size_t extra)
{
    size_t *perm = calloc(n + extra + 1, sizeof *perm);
    if (!perm)
        die("out of memory");
    for (size_t i = 0; i < n; i++)
        perm[i] = i;
    return perm;
}

static void print_ray(const queue *q, size_t i)
{
    printf("ray=%zu pixel=%u\n", i, ((const rto_wf_ray *)q->rays.data)[i].pixel);
}

/* Copies what a GPU harness dumps: the frame's buffers, not the scene's or the manifest. */
static void copy_dump(const char *bundle, const char *gpu)
{
    if (mkdir(gpu, 0777) != 0)
        die(errno == EEXIST ? "GPUDIR exists" : "cannot create GPUDIR");
    static const rto_bundle_file frame_files[] = {RTO_FILE_EMIT_COUNTS, RTO_FILE_INDIRECT_ARGS,
                                                  RTO_FILE_FRAME_COUNTERS, RTO_FILE_ACCUM, RTO_FILE_IMAGE};
    for (size_t k = 0; k < sizeof frame_files / sizeof frame_files[0]; k++)
        if (exists(path_of(bundle, fname(frame_files[k], 0))))
            copy_file(path_of(bundle, fname(frame_files[k], 0)), path_of(gpu, fname(frame_files[k], 0)));
    for (uint32_t d = 0; d <= D; d++) {
        static const rto_bundle_file per[] = {RTO_FILE_BOUNCE_RAYS, RTO_FILE_BOUNCE_HITS, RTO_FILE_BOUNCE_PAYLOADS};
        for (size_t k = 0; k < 3; k++)
            if (exists(path_of(bundle, fname(per[k], d))))
                copy_file(path_of(bundle, fname(per[k], d)), path_of(gpu, fname(per[k], d)));
    }
}

/* The first pixel at or after the middle that the bundle's mask leaves comparable. */
static uint32_t comparable_pixel(const char *bundle)
{
    rto_npy nc = {0};
    load(path_of(bundle, fname(RTO_FILE_NOT_COMPARABLE, 0)), &nc);
    const uint8_t *m = nc.data;
    const uint32_t n = W * H;
    for (uint32_t k = 0; k < n; k++) {
        const uint32_t p = (n / 2 + k) % n;
        if (!m[p]) {
            rto_npy_free(&nc);
            return p;
        }
    }
    die("no comparable pixel");
}

static void rewrite_words(const char *gpu, rto_bundle_file f, uint32_t d, rto_layout layout, int flat_f32)
{
    const char *path = path_of(gpu, fname(f, d));
    if (!exists(path))
        return;
    rto_npy a = {0};
    load(path, &a);
    const size_t n = (size_t)a.desc.shape[0], words = rto_layout_size(layout) / 4;
    rto_npy_desc d2 = flat_f32 ? rto_npy_desc_array(RTO_DTYPE_F32, 1, n * words, 0, 0)
                               : rto_npy_desc_array(RTO_DTYPE_U32, 2, n, words, 0);
    save(path, &d2, a.data);
    rto_npy_free(&a);
}

int main(int argc, char **argv)
{
    if (argc < 4 || argc > 5)
        die("usage: frame_mutate MUTATION BUNDLE GPUDIR [D]");
    const char *mut = argv[1], *bundle = argv[2], *gpu = argv[3];
    const uint32_t d = argc == 5 ? (uint32_t)strtoul(argv[4], NULL, 10) : 0;
    rto_npy emit = {0}, nc = {0};
    load(path_of(bundle, fname(RTO_FILE_EMIT_COUNTS, 0)), &emit);
    load(path_of(bundle, fname(RTO_FILE_NOT_COMPARABLE, 0)), &nc);
    D = (uint32_t)emit.desc.shape[0] - 1;
    H = (uint32_t)nc.desc.shape[0];
    W = (uint32_t)nc.desc.shape[1];
    rto_npy_free(&nc);
    if (d > D && strcmp(mut, "image-pixels"))
        die("no such queue");
    copy_dump(bundle, gpu);

    if (!strcmp(mut, "copy")) {
    } else if (!strcmp(mut, "shuffle") || !strcmp(mut, "missing") || !strcmp(mut, "duplicate") ||
               !strcmp(mut, "ray-dir") || !strcmp(mut, "payload") || !strcmp(mut, "payload-small") ||
               !strcmp(mut, "prim") || !strncmp(mut, "hit-", 4)) {
        queue q;
        queue_load(gpu, d, &q);
        if (!q.n)
            die("the queue is empty");
        size_t *perm = identity(q.n, 1), m = q.n, mid = q.n / 2;
        if (!strcmp(mut, "shuffle")) {
            for (size_t i = q.n - 1; i > 0; i--) { /* Fisher-Yates with the project's counter-based PRNG */
                const size_t j = rto_rng(12345u, (uint32_t)i) % (i + 1);
                const size_t t = perm[i];
                perm[i] = perm[j];
                perm[j] = t;
            }
        } else if (!strcmp(mut, "missing")) {
            print_ray(&q, mid);
            memmove(perm + mid, perm + mid + 1, (q.n - mid - 1) * sizeof *perm);
            m = q.n - 1;
        } else if (!strcmp(mut, "duplicate")) {
            print_ray(&q, mid);
            perm[q.n] = mid;
            m = q.n + 1;
        } else if (!strcmp(mut, "ray-dir")) {
            print_ray(&q, mid);
            ((rto_wf_ray *)q.rays.data)[mid].dir[0] += 0.01f;
        } else if (!strcmp(mut, "payload") || !strcmp(mut, "payload-small")) {
            if (!q.has_pay || !q.pay.desc.shape[1])
                die("the queue has no payloads");
            print_ray(&q, mid);
            uint32_t *w = (uint32_t *)q.pay.data + mid * (size_t)q.pay.desc.shape[1];
            float f;
            memcpy(&f, w, 4);
            f = !strcmp(mut, "payload") ? f + 1.0f : (float)((double)f + 0.5 * (1e-4 * fabs((double)f) + 1e-6));
            memcpy(w, &f, 4);
        } else {
            if (!q.has_hits)
                die("the queue has no hits");
            rto_hit_record *h = q.hits.data;
            const int uv = !strcmp(mut, "hit-uv");
            size_t i = 0;
            while (i < q.n && (h[(mid + i) % q.n].miss_flag ||
                               (uv && fabsf(h[(mid + i) % q.n].bary[0] - h[(mid + i) % q.n].bary[1]) <= 0.01f)))
                i++;
            if (i == q.n)
                die("no hit to mutate");
            const size_t at = (mid + i) % q.n;
            print_ray(&q, at);
            rto_hit_record *r = &h[at];
            if (uv) {
                const float u = r->bary[0];
                r->bary[0] = r->bary[1];
                r->bary[1] = u;
            } else if (!strcmp(mut, "hit-custom")) {
                r->custom_index += 1;
            } else if (!strcmp(mut, "hit-group")) {
                r->hit_group += 3;
            } else if (!strcmp(mut, "hit-transform")) {
                r->obj_to_world[3][1] += 1.0f;
            } else if (!strcmp(mut, "hit-tmin")) {
                const float t_min = ((const rto_wf_ray *)q.rays.data)[at].t_min;
                r->t = t_min - 1.0f - fabsf(t_min);
            } else if (!strcmp(mut, "prim")) {
                r->prim_id ^= 2u;
            } else {
                die("unknown mutation");
            }
        }
        queue_save(gpu, d, &q, perm, m);
        free(perm);
        queue_free(&q);
    } else if (!strcmp(mut, "emit") || !strcmp(mut, "indirect")) {
        const int is_emit = !strcmp(mut, "emit");
        const char *path = path_of(gpu, fname(is_emit ? RTO_FILE_EMIT_COUNTS : RTO_FILE_INDIRECT_ARGS, 0));
        rto_npy a = {0};
        load(path, &a);
        ((uint32_t *)a.data)[is_emit ? d : 3 * (size_t)d] += 1;
        save(path, &a.desc, a.data);
        rto_npy_free(&a);
    } else if (!strcmp(mut, "accum-big") || !strcmp(mut, "accum-small")) {
        const char *path = path_of(gpu, fname(RTO_FILE_ACCUM, 0));
        rto_npy a = {0};
        load(path, &a);
        const uint32_t p = comparable_pixel(bundle);
        float *v = (float *)a.data + 4 * (size_t)p;
        const double tol = 1e-4 * fabs((double)v[0]) + 1e-6;
        v[0] = (float)((double)v[0] + (!strcmp(mut, "accum-big") ? 10.0 : 0.5) * tol);
        save(path, &a.desc, a.data);
        rto_npy_free(&a);
        printf("pixel=%u x=%u y=%u\n", p, p % W, p / W);
    } else if (!strcmp(mut, "image-shift")) {
        const char *path = path_of(gpu, fname(RTO_FILE_IMAGE, 0));
        rto_image img = {0};
        rto_msg msg = {{0}};
        if (rto_image_read(path, &img, &msg))
            die(msg.text);
        uint8_t *px = img.pixels;
        const size_t ch = img.channels;
        for (uint32_t y = 0; y < img.height; y++)
            memmove(px + ((size_t)y * img.width + 1) * ch, px + (size_t)y * img.width * ch, (img.width - 1) * ch);
        if (rto_image_write(path, &img, &msg))
            die(msg.text);
        rto_image_free(&img);
    } else if (!strcmp(mut, "image-pixels")) {
        const char *path = path_of(gpu, fname(RTO_FILE_IMAGE, 0));
        rto_image img = {0};
        rto_msg msg = {{0}};
        if (rto_image_read(path, &img, &msg))
            die(msg.text);
        uint8_t *px = img.pixels;
        const size_t ch = img.channels, n = (size_t)img.width * img.height;
        /* +-1 everywhere is within the rule; the N chosen pixels then get 2 instead */
        for (size_t k = 0; k < n * ch; k++)
            px[k] = px[k] == 255 ? 254 : px[k] + 1;
        rto_npy m = {0};
        load(path_of(bundle, fname(RTO_FILE_NOT_COMPARABLE, 0)), &m);
        const uint8_t *mask = m.data, *orig = NULL;
        rto_image o = {0};
        if (rto_image_read(path_of(bundle, fname(RTO_FILE_IMAGE, 0)), &o, &msg))
            die(msg.text);
        orig = o.pixels;
        uint32_t done = 0;
        for (size_t k = 0; k < n && done < d; k++) {
            const size_t p = (n / 2 + k) % n;
            if (mask[p])
                continue;
            if (!done)
                printf("pixel=%zu x=%zu y=%zu\n", p, p % W, p / W);
            px[p * ch] = orig[p * o.channels] >= 128 ? orig[p * o.channels] - 2 : orig[p * o.channels] + 2;
            done++;
        }
        rto_image_free(&o);
        rto_npy_free(&m);
        if (rto_image_write(path, &img, &msg))
            die(msg.text);
        rto_image_free(&img);
    } else if (!strcmp(mut, "accum-exr")) {
        const char *path = path_of(gpu, fname(RTO_FILE_ACCUM, 0));
        rto_npy a = {0};
        load(path, &a);
        rto_image img = {W, H, 4, RTO_PIXEL_F32, a.data};
        rto_msg msg = {{0}};
        if (rto_image_write(path_of(gpu, fname(RTO_FILE_ACCUM_EXR, 0)), &img, &msg))
            die(msg.text);
        rto_npy_free(&a);
        if (remove(path))
            die("cannot remove accum.npy");
    } else if (!strcmp(mut, "words")) {
        for (uint32_t k = 0; k <= D; k++) {
            rewrite_words(gpu, RTO_FILE_BOUNCE_RAYS, k, RTO_LAYOUT_WF_RAY, 0);
            rewrite_words(gpu, RTO_FILE_BOUNCE_HITS, k, RTO_LAYOUT_HIT_RECORD, 1);
        }
        rewrite_words(gpu, RTO_FILE_FRAME_COUNTERS, 0, RTO_LAYOUT_FRAME_COUNTERS, 0);
    } else if (!strcmp(mut, "full")) {
        const size_t cap = 2 * (size_t)W * H;
        for (uint32_t k = 0; k <= D; k++) {
            static const rto_bundle_file files[2] = {RTO_FILE_BOUNCE_RAYS, RTO_FILE_BOUNCE_HITS};
            static const rto_layout layouts[2] = {RTO_LAYOUT_WF_RAY, RTO_LAYOUT_HIT_RECORD};
            for (int f = 0; f < 2; f++) {
                const char *pp = path_of(gpu, fname(files[f], k));
                if (!exists(pp))
                    continue;
                rto_npy a = {0};
                load(pp, &a);
                const size_t rec = rto_layout_size(layouts[f]);
                unsigned char *buf = malloc(cap * rec);
                if (!buf)
                    die("out of memory");
                memset(buf, 0xAB, cap * rec); /* what a buffer holds past the queue: anything */
                memcpy(buf, a.data, (size_t)a.desc.shape[0] * rec);
                rto_npy_desc dd = rto_layout_desc(layouts[f], cap);
                save(pp, &dd, buf);
                free(buf);
                rto_npy_free(&a);
            }
        }
    } else if (!strcmp(mut, "store")) {
        for (uint32_t k = 0; k <= D; k++) {
            const char *pp = path_of(gpu, fname(RTO_FILE_BOUNCE_PAYLOADS, k));
            if (!exists(pp))
                continue;
            queue q;
            queue_load(gpu, k, &q);
            const size_t pw = (size_t)q.pay.desc.shape[1], slots = 2 * (size_t)W * H;
            uint32_t *store = calloc(slots * pw + 1, 4);
            if (!store)
                die("out of memory");
            for (size_t i = 0; i < q.n; i++) {
                const uint32_t s = ((const rto_wf_ray *)q.rays.data)[i].payload_slot;
                memcpy(store + s * pw, (const uint32_t *)q.pay.data + i * pw, pw * 4);
            }
            rto_npy_desc ds = rto_npy_desc_array(RTO_DTYPE_U32, 2, slots, pw, 0);
            save(pp, &ds, store);
            free(store);
            queue_free(&q);
        }
    } else if (!strcmp(mut, "not-comparable")) {
        load(path_of(bundle, fname(RTO_FILE_NOT_COMPARABLE, 0)), &nc);
        const uint8_t *m = nc.data;
        size_t marked = 0;
        rto_npy a = {0};
        const char *ap = path_of(gpu, fname(RTO_FILE_ACCUM, 0));
        rto_image img = {0};
        rto_msg msg = {{0}};
        const char *ip = path_of(gpu, fname(RTO_FILE_IMAGE, 0));
        const int has_img = exists(ip);
        load(ap, &a);
        if (has_img && rto_image_read(ip, &img, &msg))
            die(msg.text);
        for (size_t p = 0; p < (size_t)W * H; p++) {
            if (!m[p])
                continue;
            marked++;
            for (int c = 0; c < 3; c++)
                ((float *)a.data)[4 * p + c] += 1.0f;
            if (has_img)
                for (uint32_t c = 0; c < 3 && c < img.channels; c++)
                    ((uint8_t *)img.pixels)[p * img.channels + c] ^= 0x80u;
        }
        save(ap, &a.desc, a.data);
        if (has_img && rto_image_write(ip, &img, &msg))
            die(msg.text);
        rto_image_free(&img);
        rto_npy_free(&a);
        rto_npy cnt = {0};
        load(path_of(bundle, fname(RTO_FILE_FRAME_COUNTERS, 0)), &cnt);
        const rto_frame_counters *fc = cnt.data;
        uint32_t first = UINT32_MAX;
        for (uint32_t k = 0; k <= D && first == UINT32_MAX; k++)
            if (fc[k].dropped)
                first = k;
        for (uint32_t k = first; first != UINT32_MAX && k <= D; k++) {
            if (!exists(path_of(gpu, fname(RTO_FILE_BOUNCE_RAYS, k))))
                continue;
            queue q;
            queue_load(gpu, k, &q);
            size_t *perm = identity(q.n, 0);
            for (size_t i = 0; i < q.n; i++)
                perm[i] = q.n - 1 - i;
            if (q.n)
                ((rto_wf_ray *)q.rays.data)[0].origin[1] += 0.5f; /* the GPU kept a ray the oracle dropped */
            queue_save(gpu, k, &q, perm, q.n);
            free(perm);
            queue_free(&q);
        }
        rto_npy_free(&cnt);
        rto_npy_free(&nc);
        printf("pixels=%zu queue=%d\n", marked, first == UINT32_MAX ? -1 : (int)first);
    } else {
        die("unknown mutation");
    }
    rto_npy_free(&emit);
    return 0;
}

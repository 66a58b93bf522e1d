/* The visibility pass's reference (DESIGN.md §11.1-11.4): instanced triangles drawn in instance, then primitive order
 * into a multisampled G-buffer with depth test `less` against 1.0, at the reference precision p = 8, and every
 * sample's admissible set (§11.3): the triangles some admissible rasterization may show there.
 *
 * Work is split by rows: the image is cut into bands of BAND_ROWS rows, band b goes to worker b mod workers, and
 * every band runs every triangle whose bounds reach it, in draw order, restricted to its rows. Each sample sees the
 * same triangles in the same order whatever the split, so the output does not depend on the thread count.
 *
 * One pass over a band's triangles keeps, per sample, the reference winner (its binary32 depth) and the bound B: the
 * smallest depth-interval end among the triangles that certainly cover the sample (1, the clear value, when none
 * does), and collects each possibly covering triangle whose interval starts at or below B so far (B only falls, so
 * one above it is never admissible), and ORs the precisions at which each triangle drawn before 1.0 covers the sample
 * under every midpoint variant; the survivors of the final B, with background where B is 1 and some precision is
 * missing from that OR, are the sample's admissible set. Depth intervals are first bounded from the setup's margins and computed over every choice only
 * where that bound cannot decide. */
#include "raster_setup.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define BAND_ROWS 16u
#define NO_TRI UINT32_MAX
#define BG_FLAG 0x80000000u /* on a sample's count while a band waits for its offsets: background is admissible */

typedef struct cand {
    uint32_t k, t;
    double lo;
} cand;

typedef struct band {
    uint32_t *rec; /* (sample within the band, triangle) pairs, in draw order */
    size_t n, cap;
    uint64_t total, base;
    rto_vbuffer_stats st;
} band;

typedef struct job {
    rto_raster *r;
    const rto_vbuffer_geometry *g;
    rto_vbuffer *vb;
    uint32_t W, H, S, nbands;
    band *bands;
    rs_box *box;
    uint64_t vtx_total, total;
    int failed[RTO_THREADS_MAX];
    int alloc_failed;
    uint64_t clipped[RTO_THREADS_MAX];
} job;

/* ---------------------------------------------------------------------------------------------------------------- */
/* Geometry                                                                                                           */

static void raster_free(rto_raster *r)
{
    if (!r)
        return;
    free(r->tri_base);
    free(r->vtx_base);
    free(r->inst_mesh);
    free(r->idx_base);
    free(r->indices);
    free(r->world);
    free(r->clip);
    free(r);
}

/* Checks the geometry and copies what evaluations need (the indices); vertices are transformed by the workers. */
static rto_status raster_new(const rto_vbuffer_geometry *g, const rto_vbuffer_camera *cam, const rto_vbuffer_desc *d,
                             rto_raster **out, uint64_t *vtx_total, rto_msg *msg)
{
    if (g->instance_count && !g->instances)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: %u instances and no instance array",
                         g->instance_count);
    if (g->mesh_count && !g->meshes)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: %u meshes and no mesh array", g->mesh_count);
    uint64_t idx_total = 0;
    for (uint32_t m = 0; m < g->mesh_count; m++) {
        const rto_mesh *mesh = &g->meshes[m];
        if ((mesh->triangle_count && !mesh->indices) || (mesh->vertex_count && !mesh->positions))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: mesh %u has no %s", m,
                             mesh->positions ? "indices" : "positions");
        for (uint64_t i = 0; i < 3 * (uint64_t)mesh->triangle_count; i++)
            if (mesh->indices[i] >= mesh->vertex_count)
                return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT,
                                 "vbuffer: mesh %u index %llu is %u, not below its %u vertices", m,
                                 (unsigned long long)i, mesh->indices[i], mesh->vertex_count);
        idx_total += 3 * (uint64_t)mesh->triangle_count;
    }
    uint64_t tris = 0, verts = 0;
    for (uint32_t i = 0; i < g->instance_count; i++) {
        if (g->instances[i].blas >= g->mesh_count)
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: instance %u draws mesh %u of %u", i,
                             g->instances[i].blas, g->mesh_count);
        tris += g->meshes[g->instances[i].blas].triangle_count;
        verts += g->meshes[g->instances[i].blas].vertex_count;
    }
    if (tris >= NO_TRI)
        return rto__fail(msg, RTO_ERR_UNSUPPORTED, "vbuffer: %llu triangles (at most 2^32 - 2)",
                         (unsigned long long)tris);
    rto_raster *r = calloc(1, sizeof *r);
    if (!r)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "vbuffer: out of memory");
    static atomic_uint_fast64_t next_id = 1;
    r->id = atomic_fetch_add(&next_id, 1);
    r->width = d->width;
    r->height = d->height;
    r->samples = d->samples;
    memcpy(r->vp, cam->view_proj, sizeof r->vp);
    r->instance_count = g->instance_count;
    r->mesh_count = g->mesh_count;
    r->tri_count = (uint32_t)tris;
    r->tri_base = rto__alloc(g->instance_count + (size_t)1, sizeof *r->tri_base);
    r->vtx_base = rto__alloc(g->instance_count + (size_t)1, sizeof *r->vtx_base);
    r->inst_mesh = rto__alloc(g->instance_count, sizeof *r->inst_mesh);
    r->idx_base = rto__alloc(g->mesh_count, sizeof *r->idx_base);
    r->indices = rto__alloc(idx_total, sizeof *r->indices);
    r->world = rto__alloc(verts, 3 * sizeof *r->world);
    r->clip = rto__alloc(verts, 4 * sizeof *r->clip);
    if (!r->tri_base || !r->vtx_base || !r->inst_mesh || !r->idx_base || !r->indices || !r->world || !r->clip) {
        raster_free(r);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "vbuffer: out of memory (%llu triangles, %llu vertices)",
                         (unsigned long long)tris, (unsigned long long)verts);
    }
    uint64_t at = 0;
    for (uint32_t m = 0; m < g->mesh_count; m++) {
        r->idx_base[m] = at;
        if (g->meshes[m].triangle_count)
            memcpy(r->indices + at, g->meshes[m].indices, 3 * (size_t)g->meshes[m].triangle_count * sizeof(uint32_t));
        at += 3 * (uint64_t)g->meshes[m].triangle_count;
    }
    tris = verts = 0;
    for (uint32_t i = 0; i < g->instance_count; i++) {
        r->tri_base[i] = (uint32_t)tris;
        r->vtx_base[i] = verts;
        r->inst_mesh[i] = g->instances[i].blas;
        tris += g->meshes[g->instances[i].blas].triangle_count;
        verts += g->meshes[g->instances[i].blas].vertex_count;
    }
    r->tri_base[g->instance_count] = (uint32_t)tris;
    r->vtx_base[g->instance_count] = verts;
    *vtx_total = verts;
    *out = r;
    return RTO_OK;
}

/* §11.1: world = objToWorld p (binary32, §5's order), clip_r = ((vp[r][0] x + vp[r][1] y) + vp[r][2] z) + vp[r][3]
 * in binary32; view_proj is column-major (element [4c + r] is row r, column c). */
static void transform_range(job *j, uint64_t b, uint64_t e)
{
    rto_raster *r = j->r;
    if (b >= e)
        return;
    uint32_t lo = 0, hi = r->instance_count; /* the instance holding vertex b */
    while (hi - lo > 1) {
        const uint32_t m = lo + (hi - lo) / 2;
        if (r->vtx_base[m] <= b)
            lo = m;
        else
            hi = m;
    }
    const float *vp = r->vp;
    for (uint32_t i = lo; i < r->instance_count && r->vtx_base[i] < e; i++) {
        const rto_mesh *mesh = &j->g->meshes[r->inst_mesh[i]];
        const uint64_t v0 = r->vtx_base[i] > b ? r->vtx_base[i] : b;
        const uint64_t v1 = r->vtx_base[i + 1] < e ? r->vtx_base[i + 1] : e;
        for (uint64_t v = v0; v < v1; v++) {
            const float *p = mesh->positions + 3 * (v - r->vtx_base[i]);
            const rto_vec3 wp = rto_mat34_point(&j->g->instances[i].obj_to_world, (rto_vec3){p[0], p[1], p[2]});
            float *w = r->world + 3 * v, *c = r->clip + 4 * v;
            w[0] = wp.x;
            w[1] = wp.y;
            w[2] = wp.z;
            for (int row = 0; row < 4; row++)
                c[row] = ((vp[row] * wp.x + vp[4 + row] * wp.y) + vp[8 + row] * wp.z) + vp[12 + row];
        }
    }
}

static void bounds_range(job *j, uint32_t w, uint32_t b, uint32_t e)
{
    if (b >= e)
        return;
    uint32_t inst = rto__rs_instance_of(j->r, b);
    for (uint32_t t = b; t < e; t++) {
        while (t >= j->r->tri_base[inst + 1])
            inst++;
        if (rto__rs_bounds(j->r, inst, t, &j->box[t]) == RS_HOMOG)
            j->clipped[w]++;
    }
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* Bands                                                                                                              */

typedef struct scratch {
    rs_tri *tri, *ref;
    uint32_t *rtri;
    float *rdepth;
    double *bound;
    uint8_t *pcov; /* RS_PCOV bits >> RS_PCOV_SHIFT, ORed over the triangles drawn at the sample before 1.0 */
    cand *cands;
    size_t ncand, capcand;
} scratch;

static int push_cand(scratch *sc, uint32_t k, uint32_t t, double lo)
{
    if (sc->ncand == sc->capcand) {
        const size_t cap = sc->capcand ? 2 * sc->capcand : 4096;
        cand *c = realloc(sc->cands, cap * sizeof *c);
        if (!c)
            return 0;
        sc->cands = c;
        sc->capcand = cap;
    }
    sc->cands[sc->ncand++] = (cand){k, t, lo};
    return 1;
}

static int push_rec(band *b, uint32_t k, uint32_t t)
{
    if (b->n == b->cap) {
        const size_t cap = b->cap ? 2 * b->cap : 4096;
        uint32_t *p = realloc(b->rec, cap * 2 * sizeof *p);
        if (!p)
            return 0;
        b->rec = p;
        b->cap = cap;
    }
    b->rec[2 * b->n] = k;
    b->rec[2 * b->n + 1] = t;
    b->n++;
    return 1;
}

/* The planes of one sample (§11.4). */
static void write_sample(rto_vbuffer_planes *pl, size_t kg, const rs_tri *t, const double *a, const float n16[2],
                         float depth)
{
    uint16_t *v = pl->visibility + 4 * kg, *b = pl->barycentric + 2 * kg, *n = pl->normal + 4 * kg,
             *d = pl->derivatives + 4 * kg;
    if (!t) {
        v[0] = v[1] = v[2] = v[3] = 0xFFFFu;
        b[0] = b[1] = 0;
        n[0] = n[1] = n[2] = n[3] = 0;
        d[0] = d[1] = d[2] = d[3] = 0;
        pl->depth[kg] = 1.0f;
        pl->depth_unorm24[kg] = 0xFFFFFFu;
        return;
    }
    v[0] = (uint16_t)(t->prim & 0xFFFFu);
    v[1] = (uint16_t)(t->prim >> 16);
    v[2] = (uint16_t)(t->instance & 0xFFFFu);
    v[3] = (uint16_t)(t->instance >> 16);
    b[0] = rto_f16_from_f32((float)a[0]);
    b[1] = rto_f16_from_f32((float)a[1]);
    n[0] = rto_f16_from_f32(n16[0]);
    n[1] = rto_f16_from_f32(n16[1]);
    n[2] = 0;      /* tangent angle 0 */
    n[3] = 0x3C00; /* handedness 1 */
    for (int j = 0; j < 4; j++)
        d[j] = rto_f16_from_f32((float)a[2 + j]);
    pl->depth[kg] = depth;
    /* depth24plus as unorm24 of the binary32 depth: exact product (24 x 24 bits), nearest even. */
    pl->depth_unorm24[kg] = (uint32_t)rint((double)depth * 16777215.0);
}

static int band_run(job *j, scratch *sc, uint32_t bi)
{
    const rto_raster *r = j->r;
    const uint32_t W = j->W, S = j->S, ya = bi * BAND_ROWS, yb = ya + BAND_ROWS < j->H ? ya + BAND_ROWS : j->H;
    const size_t n = (size_t)(yb - ya) * W * S, k0 = (size_t)ya * W * S;
    band *bd = &j->bands[bi];
    for (size_t k = 0; k < n; k++) {
        sc->rtri[k] = NO_TRI;
        sc->rdepth[k] = 1.0f;
        sc->bound[k] = 1.0;
        sc->pcov[k] = 0;
    }
    sc->ncand = 0;
    int64_t ox[4], oy[4];
    for (uint32_t s = 0; s < S; s++) {
        double fx, fy;
        rto__vb_sample_pos(S, s, &fx, &fy);
        ox[s] = (int64_t)(fx * RS_SUB);
        oy[s] = (int64_t)(fy * RS_SUB);
    }
    uint32_t inst = 0;
    for (uint32_t t = 0; t < r->tri_count; t++) {
        const rs_box *bx = &j->box[t];
        if (bx->x0 > bx->x1 || bx->y0 > bx->y1 || bx->y1 < (int32_t)ya || bx->y0 >= (int32_t)yb)
            continue;
        while (t >= r->tri_base[inst + 1])
            inst++;
        const rs_box reg = {bx->x0, bx->y0 > (int32_t)ya ? bx->y0 : (int32_t)ya, bx->x1,
                            bx->y1 < (int32_t)yb - 1 ? bx->y1 : (int32_t)yb - 1};
        rs_tri *tr = sc->tri;
        rto__rs_setup(r, inst, t, 1, &reg, tr);
        if (tr->kind == RS_NONE)
            continue;
        for (int32_t y = reg.y0; y <= reg.y1; y++)
            for (int32_t x = reg.x0; x <= reg.x1; x++)
                for (uint32_t s = 0; s < S; s++) {
                    const int64_t X = (int64_t)x * RS_SUB + ox[s], Y = (int64_t)y * RS_SUB + oy[s];
                    const int c = rto__rs_classify(tr, X, Y);
                    if (!(c & RS_POSSIBLE))
                        continue;
                    const uint32_t k = (uint32_t)((((size_t)(y - (int32_t)ya) * W) + (size_t)x) * S + s);
                    if (c & RS_REF) {
                        const float z = (float)rto__rs_ref_depth(tr, X, Y);
                        if (z < sc->rdepth[k]) { /* depth test `less`, drawn in order */
                            sc->rdepth[k] = z;
                            sc->rtri[k] = t;
                        }
                    }
                    double lo, hi;
                    rto__rs_depth_coarse(tr, X, Y, &lo, &hi);
                    if (lo >= 1.0 || lo > sc->bound[k])
                        continue;
                    rto__rs_depth_exact(tr, X, Y, &lo, &hi);
                    if ((c & RS_CERTAIN) && hi < sc->bound[k])
                        sc->bound[k] = hi;
                    if (hi < 1.0) /* drawn over the clear depth at every choice: covering at the precisions it covers */
                        sc->pcov[k] |= (uint8_t)((c & RS_PCOV_ALL) >> RS_PCOV_SHIFT);
                    if (lo < 1.0 && lo <= sc->bound[k] && !push_cand(sc, k, t, lo))
                        return 0;
                }
    }
    /* The admissible sets: candidates at or below the final bound; background where no triangle certainly draws and
     * some precision p leaves the sample to the clear value (no triangle drawn before 1.0 covers it under every
     * midpoint variant at p): a shared edge that each of its two triangles covers at some precisions only is covered
     * at all of them, a crack is not admissible. */
    uint32_t *count = j->vb->admissible_offset + k0 + 1;
    memset(count, 0, n * sizeof *count);
    bd->n = 0;
    for (size_t i = 0; i < sc->ncand; i++) {
        const cand *c = &sc->cands[i];
        if (c->lo <= sc->bound[c->k]) {
            if (!push_rec(bd, c->k, c->t))
                return 0;
            count[c->k]++;
        }
    }
    bd->total = bd->n;
    for (size_t k = 0; k < n; k++)
        if (sc->bound[k] >= 1.0 && sc->pcov[k] != RS_PCOV_ALL >> RS_PCOV_SHIFT) {
            /* background, last of the set (band_scatter): a flag, not a record */
            count[k] = (count[k] + 1) | BG_FLAG;
            bd->total++;
        }
    /* The reference planes and the statistics. */
    rto_vbuffer_stats *st = &bd->st;
    memset(st, 0, sizeof *st);
    st->samples = n;
    uint32_t cached = NO_TRI;
    float n16[2] = {0.0f, 0.0f};
    for (uint32_t y = ya; y < yb; y++)
        for (uint32_t x = 0; x < W; x++) {
            uint32_t pix_t = NO_TRI;
            double a[7] = {0};
            for (uint32_t s = 0; s < S; s++) {
                const size_t k = ((size_t)(y - ya) * W + x) * S + s;
                const uint32_t t = sc->rtri[k];
                const uint32_t m = count[k] & ~BG_FLAG;
                st->max_set = m > st->max_set ? m : st->max_set;
                if (m) /* never 0: the triangle that sets the bound is admitted, else background is, else the
                        * triangles that cover at every precision are (their intervals start below 1) */
                    st->set_sizes[(m < 5 ? m : 5) - 1]++;
                if (m == 1)
                    st->certain++;
                else
                    st->uncertain++;
                if (t == NO_TRI) {
                    write_sample(&j->vb->planes, k0 + k, NULL, NULL, NULL, 1.0f);
                    continue;
                }
                st->covered++;
                if (t != cached) {
                    rto__rs_setup(r, rto__rs_instance_of(r, t), t, 0, NULL, sc->ref);
                    float nrm[3];
                    rto__rs_normal(sc->ref, nrm);
                    rto__oct_encode(nrm, n16);
                    cached = t;
                }
                if (t != pix_t) {
                    rto__rs_ref_attr(sc->ref, x, y, (int64_t)x * RS_SUB + ox[s], (int64_t)y * RS_SUB + oy[s], a);
                    pix_t = t;
                }
                write_sample(&j->vb->planes, k0 + k, sc->ref, a, n16, sc->rdepth[k]);
            }
        }
    return 1;
}

static void bands_run(job *j, uint32_t w, uint32_t nw)
{
    scratch sc;
    memset(&sc, 0, sizeof sc);
    const size_t n = (size_t)BAND_ROWS * j->W * j->S;
    sc.tri = malloc(sizeof *sc.tri);
    sc.ref = malloc(sizeof *sc.ref);
    sc.rtri = rto__alloc(n, sizeof *sc.rtri);
    sc.rdepth = rto__alloc(n, sizeof *sc.rdepth);
    sc.bound = rto__alloc(n, sizeof *sc.bound);
    sc.pcov = rto__alloc(n, sizeof *sc.pcov);
    if (!sc.tri || !sc.ref || !sc.rtri || !sc.rdepth || !sc.bound || !sc.pcov)
        j->failed[w] = 1;
    for (uint32_t b = w; b < j->nbands && !j->failed[w]; b += nw)
        if (!band_run(j, &sc, b))
            j->failed[w] = 1;
    free(sc.tri);
    free(sc.ref);
    free(sc.rtri);
    free(sc.rdepth);
    free(sc.bound);
    free(sc.pcov);
    free(sc.cands);
}

/* Offsets of band b's samples (counts in admissible_offset[k + 1] become ends), its records scattered in order. */
static void band_scatter(job *j, uint32_t bi)
{
    band *bd = &j->bands[bi];
    const uint32_t ya = bi * BAND_ROWS, yb = ya + BAND_ROWS < j->H ? ya + BAND_ROWS : j->H;
    const size_t n = (size_t)(yb - ya) * j->W * j->S, k0 = (size_t)ya * j->W * j->S;
    uint32_t *off = j->vb->admissible_offset + k0 + 1, *adm = j->vb->admissible;
    uint64_t at = bd->base; /* below 2^31 (vb_worker): the top bit keeps the background flag meanwhile */
    for (size_t k = 0; k < n; k++) { /* off[k]: the start of sample k, advanced as it fills */
        const uint32_t c = off[k] & ~BG_FLAG;
        off[k] = (uint32_t)at | (off[k] & BG_FLAG);
        at += c;
    }
    uint32_t inst = 0;
    for (size_t i = 0; i < bd->n; i++) {
        const uint32_t k = bd->rec[2 * i], t = bd->rec[2 * i + 1];
        const uint32_t pos = off[k]++ & ~BG_FLAG;
        if (t < j->r->tri_base[inst] || t >= j->r->tri_base[inst + 1])
            inst = rto__rs_instance_of(j->r, t);
        adm[2 * (size_t)pos] = inst;
        adm[2 * (size_t)pos + 1] = t - j->r->tri_base[inst];
    }
    for (size_t k = 0; k < n; k++) /* background last; off[k] becomes the set's end */
        if (off[k] & BG_FLAG) {
            const uint32_t pos = off[k] & ~BG_FLAG;
            adm[2 * (size_t)pos] = RTO_VB_BACKGROUND;
            adm[2 * (size_t)pos + 1] = RTO_VB_BACKGROUND;
            off[k] = pos + 1;
        }
    free(bd->rec);
    bd->rec = NULL;
}

static void vb_worker(void *arg, rto__team *team, uint32_t w, uint32_t nw)
{
    job *j = arg;
    size_t b, e;
    rto__part(j->vtx_total, w, nw, &b, &e);
    transform_range(j, b, e);
    rto__team_sync(team);
    rto__part(j->r->tri_count, w, nw, &b, &e);
    bounds_range(j, w, (uint32_t)b, (uint32_t)e);
    rto__team_sync(team);
    bands_run(j, w, nw);
    rto__team_sync(team);
    if (w == 0) {
        int failed = 0;
        for (uint32_t i = 0; i < nw; i++)
            failed |= j->failed[i];
        uint64_t at = 0;
        for (uint32_t i = 0; i < j->nbands; i++) {
            j->bands[i].base = at;
            at += j->bands[i].total;
        }
        j->total = at;
        if (!failed && at <= INT32_MAX) {
            j->vb->admissible = rto__alloc_large(2 * (size_t)at, sizeof(uint32_t));
            failed = !j->vb->admissible;
        }
        j->alloc_failed = failed || at > INT32_MAX;
    }
    rto__team_sync(team);
    if (j->alloc_failed)
        return;
    for (uint32_t bi = w; bi < j->nbands; bi += nw)
        band_scatter(j, bi);
}

/* ---------------------------------------------------------------------------------------------------------------- */
/* API                                                                                                                */

void rto_vbuffer_free(rto_vbuffer *vb)
{
    if (!vb)
        return;
    free(vb->planes.visibility);
    free(vb->planes.barycentric);
    free(vb->planes.normal);
    free(vb->planes.derivatives);
    free(vb->planes.depth);
    free(vb->planes.depth_unorm24);
    free(vb->admissible_offset);
    free(vb->admissible);
    raster_free(vb->raster);
    memset(vb, 0, sizeof *vb);
}

rto_status rto_vbuffer_make(const rto_vbuffer_geometry *geometry, const rto_vbuffer_camera *camera,
                            const rto_vbuffer_desc *desc, rto_vbuffer *out, rto_msg *msg)
{
    if (out)
        memset(out, 0, sizeof *out);
    if (!geometry || !camera || !desc || !out)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: NULL geometry, camera, description or output");
    if (desc->width == 0 || desc->height == 0 || desc->width > 16384 || desc->height > 16384)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: image size %ux%u (each 1 to 16384)", desc->width,
                         desc->height);
    if (desc->samples != 1 && desc->samples != 4)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: %u samples (1 or 4)", desc->samples);
    for (int k = 0; k < 16; k++)
        if (!isfinite(camera->view_proj[k]))
            return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "vbuffer: view_proj[%d] is not finite", k);
    job j;
    memset(&j, 0, sizeof j);
    rto_status st = raster_new(geometry, camera, desc, &j.r, &j.vtx_total, msg);
    if (st != RTO_OK)
        return st;
    const size_t n = (size_t)desc->width * desc->height * desc->samples;
    rto_vbuffer_planes *pl = &out->planes;
    pl->width = desc->width;
    pl->height = desc->height;
    pl->samples = desc->samples;
    pl->visibility = rto__alloc_large(n, 4 * sizeof(uint16_t));
    pl->barycentric = rto__alloc_large(n, 2 * sizeof(uint16_t));
    pl->normal = rto__alloc_large(n, 4 * sizeof(uint16_t));
    pl->derivatives = rto__alloc_large(n, 4 * sizeof(uint16_t));
    pl->depth = rto__alloc_large(n, sizeof(float));
    pl->depth_unorm24 = rto__alloc_large(n, sizeof(uint32_t));
    out->admissible_offset = rto__alloc_large(n + 1, sizeof(uint32_t));
    out->raster = j.r;
    out->camera = *camera;
    j.g = geometry;
    j.vb = out;
    j.W = desc->width;
    j.H = desc->height;
    j.S = desc->samples;
    j.nbands = (desc->height + BAND_ROWS - 1) / BAND_ROWS;
    j.bands = calloc(j.nbands, sizeof *j.bands);
    j.box = rto__alloc(j.r->tri_count, sizeof *j.box);
    if (!pl->visibility || !pl->barycentric || !pl->normal || !pl->derivatives || !pl->depth || !pl->depth_unorm24 ||
        !out->admissible_offset || !j.bands || !j.box) {
        free(j.bands);
        free(j.box);
        rto_vbuffer_free(out);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "vbuffer: out of memory (%ux%u, %u samples)", desc->width,
                         desc->height, desc->samples);
    }
    rto__team_run(desc->threads, vb_worker, &j);
    free(j.box);
    int failed = j.alloc_failed;
    for (uint32_t i = 0; i < j.nbands; i++)
        free(j.bands[i].rec);
    if (failed) {
        free(j.bands);
        rto_vbuffer_free(out);
        if (j.total > INT32_MAX)
            return rto__fail(msg, RTO_ERR_UNSUPPORTED, "vbuffer: %llu admissible entries (at most 2^31 - 1)",
                             (unsigned long long)j.total);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "vbuffer: out of memory");
    }
    out->admissible_offset[0] = 0;
    rto_vbuffer_stats *s = &out->stats;
    for (uint32_t i = 0; i < j.nbands; i++) {
        const rto_vbuffer_stats *b = &j.bands[i].st;
        s->samples += b->samples;
        s->covered += b->covered;
        s->certain += b->certain;
        s->uncertain += b->uncertain;
        s->max_set = b->max_set > s->max_set ? b->max_set : s->max_set;
        for (int k = 0; k < 5; k++)
            s->set_sizes[k] += b->set_sizes[k];
    }
    for (uint32_t i = 0; i < RTO_THREADS_MAX; i++)
        s->clipped_triangles += j.clipped[i];
    free(j.bands);
    return RTO_OK;
}

/* Viewpoint mutual information (SPEC F2) on item-buffer pixel lists, and the
 * greedy leaf ranking. No GL: the pixel lists come from the render module.
 *
 * Conventions: p(v) = 1/Nv, log base 2. I(v,O) is evaluated as
 *   I_v = (1/A_v) sum_o a_ov log2 a_ov - log2 A_v - (1/A_v) sum_o a_ov log2 p_o
 * (the same sum regrouped), with a table of k log2 k for integer counts, so
 * one evaluation costs n*Nv multiply-adds and n logarithms. */
#include "horizon/tree.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void hz_vmi_compute(const uint32_t *counts, uint32_t n, uint32_t nv, double *vmi)
{
    double *p = calloc(n ? n : 1, sizeof *p);
    uint64_t *A = calloc(nv ? nv : 1, sizeof *A);
    if (!p || !A) {
        free(p);
        free(A);
        for (uint32_t v = 0; v < nv; v++)
            vmi[v] = NAN;
        return;
    }
    for (uint32_t o = 0; o < n; o++)
        for (uint32_t v = 0; v < nv; v++)
            A[v] += counts[(size_t)o * nv + v];
    for (uint32_t o = 0; o < n; o++) {
        double s = 0.0;
        for (uint32_t v = 0; v < nv; v++)
            if (A[v])
                s += (double)counts[(size_t)o * nv + v] / (double)A[v];
        p[o] = s / nv;
    }
    for (uint32_t v = 0; v < nv; v++) {
        double I = 0.0;
        for (uint32_t o = 0; o < n && A[v]; o++) {
            uint32_t a = counts[(size_t)o * nv + v];
            if (a == 0)
                continue;
            double pov = (double)a / (double)A[v];
            I += pov * log2(pov / p[o]);
        }
        vmi[v] = I;
    }
    free(p);
    free(A);
}

/* ---- ranking ---------------------------------------------------------------- */

typedef struct transfer {
    uint16_t to;   /* leaf receiving the pixel, or n = background */
    uint16_t view;
} transfer;

typedef struct rank_ctx {
    uint32_t n, nv, L;
    size_t npix;
    const uint16_t *ids;
    uint16_t *view_of;     /* per pixel */
    uint8_t *front;        /* per pixel: layer of the front-most remaining leaf (L = none) */
    uint32_t *pix_start;   /* per leaf: start into pix_list (n + 1) */
    uint32_t *pix_list;    /* pixels where the leaf appears (any layer) */
    uint32_t *a;           /* counts n x nv */
    uint32_t *A;           /* per view */
    uint8_t *removed, *dirty;
    transfer **tr;         /* per leaf: its current transfers */
    uint32_t *tr_n, *tr_cap;
    /* scratch */
    uint32_t *a2, *A2;
    double *xlogx;         /* k log2 k, k = 0 .. max pixels per view */
    double *p, *I0, *I1;
    uint32_t max_count;
} rank_ctx;

static double xlogx(const rank_ctx *c, uint32_t k)
{
    return k <= c->max_count ? c->xlogx[k] : (double)k * log2((double)k);
}

/* I_v for all views from counts a (n x nv) and per-view totals A. */
static void eval(rank_ctx *c, const uint32_t *a, const uint32_t *A, double *I)
{
    const uint32_t n = c->n, nv = c->nv;
    double invA[256];
    double *inv = nv <= 256 ? invA : malloc(nv * sizeof *inv);
    if (!inv) {
        for (uint32_t v = 0; v < nv; v++)
            I[v] = 0;
        return;
    }
    for (uint32_t v = 0; v < nv; v++)
        inv[v] = A[v] ? 1.0 / (double)A[v] : 0.0;
    for (uint32_t o = 0; o < n; o++) {
        const uint32_t *ao = a + (size_t)o * nv;
        double s = 0.0;
        for (uint32_t v = 0; v < nv; v++)
            s += (double)ao[v] * inv[v];
        c->p[o] = s > 0.0 ? log2(s / nv) : 0.0; /* log2 p_o */
    }
    for (uint32_t v = 0; v < nv; v++)
        I[v] = 0.0;
    for (uint32_t o = 0; o < n; o++) {
        const uint32_t *ao = a + (size_t)o * nv;
        const double lp = c->p[o];
        for (uint32_t v = 0; v < nv; v++)
            if (ao[v])
                I[v] += xlogx(c, ao[v]) - (double)ao[v] * lp;
    }
    for (uint32_t v = 0; v < nv; v++)
        I[v] = A[v] ? I[v] * inv[v] - log2((double)A[v]) : 0.0;
    if (inv != invA)
        free(inv);
}

/* Next remaining leaf behind layer `from` at pixel p, or n. */
static uint32_t next_behind(const rank_ctx *c, size_t p, uint32_t from)
{
    const uint16_t *ids = c->ids + p * c->L;
    for (uint32_t l = from + 1; l < c->L; l++) {
        uint16_t id = ids[l];
        if (id == HZ_VMI_EMPTY)
            break;
        if (!c->removed[id])
            return id;
    }
    return c->n;
}

static bool compute_transfers(rank_ctx *c, uint32_t x)
{
    c->tr_n[x] = 0;
    for (uint32_t k = c->pix_start[x]; k < c->pix_start[x + 1]; k++) {
        size_t p = c->pix_list[k];
        uint32_t f = c->front[p];
        if (f >= c->L || c->ids[p * c->L + f] != x)
            continue;
        if (c->tr_n[x] == c->tr_cap[x]) {
            uint32_t nc = c->tr_cap[x] ? c->tr_cap[x] * 2 : 16;
            transfer *np = realloc(c->tr[x], nc * sizeof *np);
            if (!np)
                return false;
            c->tr[x] = np;
            c->tr_cap[x] = nc;
        }
        c->tr[x][c->tr_n[x]++] = (transfer){(uint16_t)next_behind(c, p, f), c->view_of[p]};
    }
    return true;
}

/* e_VMI of removing x: sum_v |I_v(O) - I_v(O \ x)|. */
static double removal_cost(rank_ctx *c, uint32_t x)
{
    const uint32_t nv = c->nv;
    memcpy(c->a2, c->a, (size_t)c->n * nv * sizeof *c->a2);
    memcpy(c->A2, c->A, nv * sizeof *c->A2);
    for (uint32_t k = 0; k < c->tr_n[x]; k++) {
        const transfer *t = &c->tr[x][k];
        c->a2[(size_t)x * nv + t->view]--;
        if (t->to < c->n)
            c->a2[(size_t)t->to * nv + t->view]++;
        else
            c->A2[t->view]--;
    }
    eval(c, c->a2, c->A2, c->I1);
    double e = 0.0;
    for (uint32_t v = 0; v < nv; v++)
        e += fabs(c->I0[v] - c->I1[v]);
    return e;
}

static void rank_free(rank_ctx *c)
{
    free(c->view_of);
    free(c->front);
    free(c->pix_start);
    free(c->pix_list);
    free(c->a);
    free(c->A);
    free(c->removed);
    free(c->dirty);
    if (c->tr)
        for (uint32_t o = 0; o < c->n; o++)
            free(c->tr[o]);
    free(c->tr);
    free(c->tr_n);
    free(c->tr_cap);
    free(c->a2);
    free(c->A2);
    free(c->xlogx);
    free(c->p);
    free(c->I0);
    free(c->I1);
}

hz_result hz_vmi_rank(const hz_vmi_input *in, uint32_t *order, hz_vmi_stats *stats, hz_err *err)
{
    if (stats)
        *stats = (hz_vmi_stats){0};
    const uint32_t n = in->leaf_count, nv = in->view_count, L = in->layers;
    if (n == 0)
        return HZ_OK;
    if (n >= HZ_VMI_EMPTY || nv == 0 || nv > 65535 || L == 0 || L > 255)
        return hz_err_set(err, HZ_ERR_VALUE, "vmi: bad sizes (%u leaves, %u views, %u layers)", n, nv, L);
    rank_ctx c = {.n = n, .nv = nv, .L = L, .npix = in->view_start[nv], .ids = in->ids};
    const size_t npix = c.npix;
    c.view_of = malloc((npix ? npix : 1) * sizeof *c.view_of);
    c.front = malloc(npix ? npix : 1);
    c.pix_start = calloc(n + 1, sizeof *c.pix_start);
    c.a = calloc((size_t)n * nv, sizeof *c.a);
    c.A = calloc(nv, sizeof *c.A);
    c.removed = calloc(n, 1);
    c.dirty = malloc(n);
    c.tr = calloc(n, sizeof *c.tr);
    c.tr_n = calloc(n, sizeof *c.tr_n);
    c.tr_cap = calloc(n, sizeof *c.tr_cap);
    c.a2 = malloc((size_t)n * nv * sizeof *c.a2);
    c.A2 = malloc(nv * sizeof *c.A2);
    c.p = malloc(n * sizeof *c.p);
    c.I0 = malloc(nv * sizeof *c.I0);
    c.I1 = malloc(nv * sizeof *c.I1);
    hz_result res = HZ_OK;
    if (!c.view_of || !c.front || !c.pix_start || !c.a || !c.A || !c.removed || !c.dirty || !c.tr || !c.tr_n ||
        !c.tr_cap || !c.a2 || !c.A2 || !c.p || !c.I0 || !c.I1) {
        res = hz_err_set(err, HZ_ERR_MEMORY, "vmi: out of memory");
        goto done;
    }
    /* Pixel -> view, front layers, initial counts, per-leaf pixel lists. */
    uint32_t maxA = 0;
    for (uint32_t v = 0; v < nv; v++) {
        if (in->view_start[v + 1] < in->view_start[v]) {
            res = hz_err_set(err, HZ_ERR_VALUE, "vmi: view_start is not increasing");
            goto done;
        }
        for (size_t p = in->view_start[v]; p < in->view_start[v + 1]; p++) {
            c.view_of[p] = (uint16_t)v;
            const uint16_t *ids = in->ids + p * L;
            c.front[p] = (uint8_t)L;
            for (uint32_t l = 0; l < L; l++) {
                if (ids[l] == HZ_VMI_EMPTY)
                    break;
                if (ids[l] >= n) {
                    res = hz_err_set(err, HZ_ERR_VALUE, "vmi: leaf id %u out of range (%u leaves)", ids[l], n);
                    goto done;
                }
                if (l == 0) {
                    c.front[p] = 0;
                    c.a[(size_t)ids[0] * nv + v]++;
                    c.A[v]++;
                }
                c.pix_start[ids[l] + 1]++;
            }
        }
        if (c.A[v] > maxA)
            maxA = c.A[v];
    }
    for (uint32_t o = 0; o < n; o++)
        c.pix_start[o + 1] += c.pix_start[o];
    c.pix_list = malloc((c.pix_start[n] ? c.pix_start[n] : 1) * sizeof *c.pix_list);
    c.max_count = maxA;
    c.xlogx = malloc(((size_t)maxA + 1) * sizeof *c.xlogx);
    uint32_t *fill = calloc(n, sizeof *fill);
    if (!c.pix_list || !c.xlogx || !fill) {
        free(fill);
        res = hz_err_set(err, HZ_ERR_MEMORY, "vmi: out of memory");
        goto done;
    }
    for (size_t p = 0; p < npix; p++) {
        const uint16_t *ids = in->ids + p * L;
        for (uint32_t l = 0; l < L && ids[l] != HZ_VMI_EMPTY; l++) {
            /* A leaf listed twice at one pixel (it cannot be) would be counted once. */
            c.pix_list[c.pix_start[ids[l]] + fill[ids[l]]++] = (uint32_t)p;
        }
    }
    free(fill);
    c.xlogx[0] = 0.0;
    for (uint32_t k = 1; k <= maxA; k++)
        c.xlogx[k] = (double)k * log2((double)k);
    memset(c.dirty, 1, n);

    /* Backward elimination. */
    for (uint32_t step = 0; step < n; step++) {
        eval(&c, c.a, c.A, c.I0);
        uint32_t best = n;
        double best_cost = INFINITY;
        uint64_t best_vis = 0;
        for (uint32_t x = 0; x < n; x++) {
            if (c.removed[x])
                continue;
            if (c.dirty[x]) {
                if (!compute_transfers(&c, x)) {
                    res = hz_err_set(err, HZ_ERR_MEMORY, "vmi: out of memory");
                    goto done;
                }
                c.dirty[x] = 0;
                if (stats)
                    stats->transfers_updated++;
            }
            /* A leaf with no front pixel changes nothing: cost 0 without evaluating. */
            double cost = c.tr_n[x] ? removal_cost(&c, x) : 0.0;
            if (stats)
                stats->candidates++;
            uint64_t vis = c.tr_n[x];
            /* Costs equal up to rounding are ties: fewer visible pixels go first. */
            double tol = 1e-12 * (1.0 + fabs(best_cost));
            if (best == n || cost < best_cost - tol || (fabs(cost - best_cost) <= tol && vis < best_vis)) {
                best = x;
                best_cost = cost;
                best_vis = vis;
            }
        }
        /* Remove it: hand its front pixels on, mark the leaves it shares pixels with. */
        uint32_t r = best;
        for (uint32_t k = c.pix_start[r]; k < c.pix_start[r + 1]; k++) {
            size_t p = c.pix_list[k];
            const uint16_t *ids = in->ids + p * L;
            for (uint32_t l = 0; l < L && ids[l] != HZ_VMI_EMPTY; l++)
                c.dirty[ids[l]] = 1;
            uint32_t f = c.front[p];
            if (f >= L || ids[f] != r)
                continue;
            uint32_t v = c.view_of[p];
            c.a[(size_t)r * nv + v]--;
            uint32_t l = f + 1;
            while (l < L && ids[l] != HZ_VMI_EMPTY && c.removed[ids[l]])
                l++;
            if (l < L && ids[l] != HZ_VMI_EMPTY) {
                c.front[p] = (uint8_t)l;
                c.a[(size_t)ids[l] * nv + v]++;
            } else {
                c.front[p] = (uint8_t)L;
                c.A[v]--;
            }
        }
        c.removed[r] = 1;
        order[n - 1 - step] = r;
        if (stats)
            stats->steps++;
    }
done:
    rank_free(&c);
    return res;
}

/* Compiled forms of the agents' and perception's inner loops (sdovon_mj/native/__init__.py builds and loads this file).
 *
 * Each function gives exactly what its Python reference gives. Three compute the same IEEE double operations in the
 * same order (nav/control.py `lattice_plan`, nav/frontier.py `OccupancyMap.integrate`'s ray carving, grid.py
 * `segment_free`; built with -ffp-contract=off, so no fused multiply-add, and -fno-builtin-pow, so `pow` is the C
 * library's as in Python's `x ** 2`), with Python's round-half-even (`nearbyint`) and the same tie-breaking of the
 * search queue. fusion.py's voxel union makes the same additions. Two give the same answers by an argument written
 * beside them: the overlap test (decided only away from the radius, else scipy's KD-tree is asked) and the grid
 * Dijkstra (a cell's distance is the least fl(d + cost) over its neighbours, whatever the queue order). The tests
 * compare both forms on many inputs. Plain C99, no Python headers: loaded with ctypes.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define FREE_CELL 1
#define OCCUPIED_CELL 2

/* floor(v) as an integer, inline: at the x86-64 baseline (no SSE4.1) `floor` is a library call per sample. Exact for
 * |v| < 2^63 (truncation toward zero, one less when that rounded up); NaN and larger values give some integer, and
 * every caller then finds it off the grid, as numpy's floor(v).astype(int64) and Python's range test do. */
static inline int64_t ifloor(double v) {
    if (!(v > -9.2e18 && v < 9.2e18))
        return INT64_MIN;
    int64_t i = (int64_t)v;
    return ((double)i > v) ? i - 1 : i;
}

/* ---- ray carving ---------------------------------------------------------------------------------------- */

/* Mark FREE every cell a ray's samples fall in (unless OCCUPIED): ray i's samples j < count[i] sit at
 * (camx + ux[i] * t[j] - ox, camy + uy[i] * t[j] - oy) / res, floored; cells off the (h, w) grid are skipped. */
void sdv_carve(int8_t *state, int64_t h, int64_t w, const double *ux, const double *uy, const int64_t *count,
               int64_t n_rays, const double *t, double camx, double camy, double ox, double oy, double res) {
    for (int64_t i = 0; i < n_rays; i++) {
        const double uxi = ux[i], uyi = uy[i];
        for (int64_t j = 0; j < count[i]; j++) {
            const double tj = t[j];
            const double yy = camy + uyi * tj - oy;
            const double xx = camx + uxi * tj - ox;
            const int64_t fr = ifloor(yy / res), fc = ifloor(xx / res);
            if (!(fr >= 0 && fr < h && fc >= 0 && fc < w))
                continue;
            int8_t *s = state + fr * w + fc;
            if (*s != OCCUPIED_CELL)
                *s = FREE_CELL;
        }
    }
}

/* ---- free segments -------------------------------------------------------------------------------------- */

/* grid.py `segment_free`: whether samples k = 0..n of a -> b (at t = k / n) all lie on nonzero cells of the (h, w)
 * mask, each cell floor((a + t * (b - a) - o) / res) per axis; a sample off the grid refuses the segment. */
int32_t sdv_segment_free(const uint8_t *mask, int64_t h, int64_t w, double ax, double ay, double bx, double by,
                         double ox, double oy, double res, int64_t n) {
    const double dx = bx - ax, dy = by - ay;
    for (int64_t k = 0; k <= n; k++) {
        const double t = (double)k / (double)n;
        const int64_t col = ifloor((ax + t * dx - ox) / res), row = ifloor((ay + t * dy - oy) / res);
        if (!(col >= 0 && col < w && row >= 0 && row < h) || !mask[row * w + col])
            return 0;
    }
    return 1;
}

/* ---- lattice A* ----------------------------------------------------------------------------------------- */

typedef struct {
    int64_t rx, ry;   /* the pose's key: position in cm (round half even), heading index */
    int64_t k;
    double x, y;      /* the pose (the latest one stored under this key) */
    int64_t g;        /* best cost so far */
    int64_t parent;   /* node index, -1 at the start */
    int32_t act;
} Node;

typedef struct {
    double f;
    int64_t ng;       /* -g: ties go to the deeper node */
    int64_t counter;  /* then to the earlier push */
    int64_t node;
} Entry;

typedef struct {
    Node *nodes;
    int64_t n, cap;
    int64_t *slots;   /* open addressing: node index + 1, 0 empty */
    int64_t n_slots;
    Entry *heap;
    int64_t hn, hcap;
} Search;

static uint64_t key_hash(int64_t rx, int64_t ry, int64_t k) {
    uint64_t h = (uint64_t)rx * 0x9E3779B97F4A7C15ULL;
    h ^= (uint64_t)ry * 0xC2B2AE3D27D4EB4FULL + (h << 6) + (h >> 2);
    h ^= (uint64_t)k * 0x165667B19E3779F9ULL + (h << 6) + (h >> 2);
    return h ^ (h >> 29);
}

static int grow_slots(Search *s) {
    int64_t n_slots = s->n_slots ? s->n_slots * 2 : 4096;
    int64_t *slots = calloc((size_t)n_slots, sizeof(int64_t));
    if (!slots)
        return -1;
    for (int64_t i = 0; i < s->n; i++) {
        const Node *nd = &s->nodes[i];
        uint64_t p = key_hash(nd->rx, nd->ry, nd->k) & (uint64_t)(n_slots - 1);
        while (slots[p])
            p = (p + 1) & (uint64_t)(n_slots - 1);
        slots[p] = i + 1;
    }
    free(s->slots);
    s->slots = slots;
    s->n_slots = n_slots;
    return 0;
}

/* Return the node index of key (rx, ry, k), creating it (g = INT64_MAX) when absent; -1 when out of memory. */
static int64_t node_of(Search *s, int64_t rx, int64_t ry, int64_t k) {
    if ((s->n + 1) * 2 > s->n_slots && grow_slots(s))
        return -1;
    uint64_t p = key_hash(rx, ry, k) & (uint64_t)(s->n_slots - 1);
    while (s->slots[p]) {
        const Node *nd = &s->nodes[s->slots[p] - 1];
        if (nd->rx == rx && nd->ry == ry && nd->k == k)
            return s->slots[p] - 1;
        p = (p + 1) & (uint64_t)(s->n_slots - 1);
    }
    if (s->n == s->cap) {
        int64_t cap = s->cap ? s->cap * 2 : 4096;
        Node *nodes = realloc(s->nodes, (size_t)cap * sizeof(Node));
        if (!nodes)
            return -1;
        s->nodes = nodes;
        s->cap = cap;
    }
    Node *nd = &s->nodes[s->n];
    nd->rx = rx; nd->ry = ry; nd->k = k; nd->g = INT64_MAX; nd->parent = -1; nd->act = -1; nd->x = 0.0; nd->y = 0.0;
    s->slots[p] = s->n + 1;
    return s->n++;
}

static int entry_less(const Entry *a, const Entry *b) {
    if (a->f != b->f)
        return a->f < b->f;
    if (a->ng != b->ng)
        return a->ng < b->ng;
    return a->counter < b->counter;
}

static int heap_push(Search *s, Entry e) {
    if (s->hn == s->hcap) {
        int64_t cap = s->hcap ? s->hcap * 2 : 4096;
        Entry *heap = realloc(s->heap, (size_t)cap * sizeof(Entry));
        if (!heap)
            return -1;
        s->heap = heap;
        s->hcap = cap;
    }
    int64_t i = s->hn++;
    while (i > 0) {
        int64_t up = (i - 1) / 2;
        if (!entry_less(&e, &s->heap[up]))
            break;
        s->heap[i] = s->heap[up];
        i = up;
    }
    s->heap[i] = e;
    return 0;
}

static Entry heap_pop(Search *s) {
    Entry top = s->heap[0], last = s->heap[--s->hn];
    int64_t i = 0;
    for (;;) {
        int64_t c = 2 * i + 1;
        if (c >= s->hn)
            break;
        if (c + 1 < s->hn && entry_less(&s->heap[c + 1], &s->heap[c]))
            c++;
        if (!entry_less(&s->heap[c], &last))
            break;
        s->heap[i] = s->heap[c];
        i = c;
    }
    if (s->hn > 0)
        s->heap[i] = last;
    return top;
}

typedef struct {
    const double *field;     /* (nr, nc) goal distance in steps, inf where unreachable */
    const uint8_t *mask;     /* (nr, nc) where the agent may stand */
    int64_t r0, c0, nr, nc;  /* the window's first row and column in the grid, its size */
    double ox, oy, res;      /* the grid frame: origin (m), resolution (m per cell) */
    double tx, ty, tol2;     /* the target (m) and the squared tolerance (m^2) */
} Grid;

/* Whether (x, y) is within the tolerance of the target (Python: ``(tx - x) ** 2 + (ty - y) ** 2 <= tol2``). */
static int arrived(const Grid *gr, double x, double y) {
    return pow(gr->tx - x, 2.0) + pow(gr->ty - y, 2.0) <= gr->tol2;
}

/* The window's flat index of the cell at world offsets (dx, dy) from the frame origin, floored per axis; -1 when the
 * cell lies outside the window (Python: ``floor(dx / res)``, ``floor(dy / res)`` and the window's range test). */
static int64_t window_cell(const Grid *gr, double dx, double dy) {
    const int64_t col = ifloor(dx / gr->res), row = ifloor(dy / gr->res);
    if (!(gr->r0 <= row && row < gr->r0 + gr->nr && gr->c0 <= col && col < gr->c0 + gr->nc))
        return -1;
    return (row - gr->r0) * gr->nc + (col - gr->c0);
}

static double heur(const Grid *gr, double x, double y) {
    if (arrived(gr, x, y))
        return 0.0;
    const int64_t cell = window_cell(gr, x - gr->ox, y - gr->oy);
    return cell < 0 ? INFINITY : gr->field[cell];
}

static int step_free(const Grid *gr, double x, double y, const double *samples, int64_t n_samples) {
    for (int64_t i = 0; i < n_samples; i++) {
        const int64_t cell = window_cell(gr, x + samples[2 * i] - gr->ox, y + samples[2 * i + 1] - gr->oy);
        if (cell < 0 || !gr->mask[cell])
            return 0;
    }
    return 1;
}

/* The search of nav/control.py `lattice_plan` (see there): returns the number of actions written to `out` (at most
 * max_nodes), -1 when the search gave up (None), -2 when out of memory. dirs: (n_head, 2) forward moves;
 * samples: (n_head, n_samples, 2) offsets checked on the mask before a forward move; acts: the action codes of
 * turning left, right and moving forward. */
int64_t sdv_lattice(const double *field, const uint8_t *mask, int64_t r0, int64_t c0, int64_t nr, int64_t nc,
                    double ox, double oy, double res, double tx, double ty, double tol2, double x0, double y0,
                    int64_t n_head, const double *dirs, const double *samples, int64_t n_samples, double weight,
                    int64_t max_nodes, int32_t act_left, int32_t act_right, int32_t act_forward, int32_t *out) {
    Grid gr = {field, mask, r0, c0, nr, nc, ox, oy, res, tx, ty, tol2};
    Search s;
    memset(&s, 0, sizeof(s));
    int64_t result = -1;
    const double h0 = heur(&gr, x0, y0);
    if (!isfinite(h0))
        return -1;
    int64_t start = node_of(&s, (int64_t)nearbyint(x0 * 100.0), (int64_t)nearbyint(y0 * 100.0), 0);
    if (start < 0) { result = -2; goto done; }
    s.nodes[start].x = x0; s.nodes[start].y = y0; s.nodes[start].g = 0;
    Entry e0 = {weight * h0, 0, 0, start};
    if (heap_push(&s, e0)) { result = -2; goto done; }
    int64_t counter = 0, expanded = 0;
    while (s.hn > 0 && expanded < max_nodes) {
        const Entry top = heap_pop(&s);
        const int64_t g = -top.ng;
        if (s.nodes[top.node].g < g)
            continue;
        expanded++;
        const double x = s.nodes[top.node].x, y = s.nodes[top.node].y;
        const int64_t k = s.nodes[top.node].k;
        if (arrived(&gr, x, y)) {
            int64_t n = 0;
            for (int64_t i = top.node; s.nodes[i].parent >= 0; i = s.nodes[i].parent)
                n++;
            int64_t j = n;
            for (int64_t i = top.node; s.nodes[i].parent >= 0; i = s.nodes[i].parent)
                out[--j] = s.nodes[i].act;
            result = n;
            goto done;
        }
        double sx[3], sy[3];
        int64_t sk[3];
        int32_t sa[3];
        int n_succ = 2;
        sx[0] = x; sy[0] = y; sk[0] = (k + 1) % n_head; sa[0] = act_left;
        sx[1] = x; sy[1] = y; sk[1] = ((k - 1) % n_head + n_head) % n_head; sa[1] = act_right;
        if (step_free(&gr, x, y, samples + 2 * n_samples * k, n_samples)) {
            sx[2] = x + dirs[2 * k]; sy[2] = y + dirs[2 * k + 1]; sk[2] = k; sa[2] = act_forward;
            n_succ = 3;
        }
        for (int i = 0; i < n_succ; i++) {
            const double hs = heur(&gr, sx[i], sy[i]);
            if (hs == INFINITY)
                continue;
            const int64_t nd = node_of(&s, (int64_t)nearbyint(sx[i] * 100.0), (int64_t)nearbyint(sy[i] * 100.0), sk[i]);
            if (nd < 0) { result = -2; goto done; }
            if (g + 1 < s.nodes[nd].g) {
                Node *p = &s.nodes[nd];
                p->g = g + 1; p->parent = top.node; p->act = sa[i]; p->x = sx[i]; p->y = sy[i];
                counter++;
                Entry e = {(double)(g + 1) + weight * hs, -(g + 1), counter, nd};
                if (heap_push(&s, e)) { result = -2; goto done; }
            }
        }
    }
done:
    free(s.nodes);
    free(s.slots);
    free(s.heap);
    return result;
}

/* ---- fusion's overlap test ------------------------------------------------------------------------------ */

/* perceive/fusion.py `_Fused.overlap` asks, per query point, whether a point of a chunk lies within the overlap
 * radius r; scipy's cKDTree answers "some point at squared distance d < r*r" (its leaf test). The chunk's points
 * come sorted by the key (ix * ny + iy) * nz + iz of their cell floor((p - o) / h), with h > r, so every point within
 * r of q sits in one of the 27 cells around q's. For each query point i with todo[i] set this writes state[i]:
 * 1 when some point lies at squared distance below `lo` (todo[i] is then cleared), else 2 when one lies below `hi`,
 * else 0 (points without todo keep their state); returns how many got 2. The caller sets lo and hi a relative 1e-9 either side of r*r, far wider than the few roundings by which
 * cKDTree's own sums can differ from these: 1 and 0 are cKDTree's answers for sure, 2 it asks cKDTree. */
int64_t sdv_near_any(const double *q, int64_t nq, uint8_t *todo, int8_t *state, const double *pts,
                     const int64_t *keys, int64_t n, double ox, double oy, double oz, double h, int64_t nx, int64_t ny,
                     int64_t nz, double lo, double hi) {
    int64_t unsure = 0;
    for (int64_t i = 0; i < nq; i++) {
        if (!todo[i])
            continue;
        const double qx = q[3 * i], qy = q[3 * i + 1], qz = q[3 * i + 2];
        const int64_t cx = ifloor((qx - ox) / h), cy = ifloor((qy - oy) / h), cz = ifloor((qz - oz) / h);
        int8_t st = 0;
        if (cx >= -1 && cx <= nx && cy >= -1 && cy <= ny && cz >= -1 && cz <= nz) {
            const int64_t z0 = cz > 0 ? cz - 1 : 0, z1 = cz + 1 < nz ? cz + 1 : nz - 1;
            for (int64_t ix = (cx > 0 ? cx - 1 : 0); ix <= cx + 1 && ix < nx && st != 1; ix++) {
                for (int64_t iy = (cy > 0 ? cy - 1 : 0); iy <= cy + 1 && iy < ny && st != 1; iy++) {
                    const int64_t first = (ix * ny + iy) * nz + z0, last = (ix * ny + iy) * nz + z1;
                    int64_t a = 0, b = n; /* the first key >= first */
                    while (a < b) {
                        const int64_t m = a + (b - a) / 2;
                        if (keys[m] < first)
                            a = m + 1;
                        else
                            b = m;
                    }
                    for (int64_t j = a; j < n && keys[j] <= last; j++) {
                        const double dx = pts[3 * j] - qx, dy = pts[3 * j + 1] - qy, dz = pts[3 * j + 2] - qz;
                        const double d = dx * dx + dy * dy + dz * dz;
                        if (d < lo) {
                            st = 1;
                            break;
                        }
                        if (d < hi)
                            st = 2;
                    }
                }
            }
        }
        state[i] = st;
        if (st == 1)
            todo[i] = 0;
        unsure += st == 2;
    }
    return unsure;
}

/* ---- fusion's voxel union ------------------------------------------------------------------------------- */

/* perceive/fusion.py `_Fused._union`: merge sorted unique old keys ok (no) with sorted unique new keys nk (nn) into
 * uk, writing per union voxel its sums (3 per voxel) and counts: old + new where both hold the voxel, 0.0 + new
 * where only the new do (the zeros the Python form starts a fresh voxel from), old where only the old do; its
 * view heights: the old one, NaN for a fresh voxel (the caller then takes fmax with the new heights, as before);
 * and each new key's slot in new_at. Returns the union's size (out arrays hold no + nn). */
int64_t sdv_union(const int64_t *ok, const double *os, const double *oc, const double *oh, int64_t no,
                  const int64_t *nk, const double *ns, const double *nc, int64_t nn, int64_t *uk, double *us,
                  double *uc, double *uh, int64_t *new_at) {
    int64_t i = 0, j = 0, u = 0;
    while (i < no || j < nn) {
        if (j >= nn || (i < no && ok[i] < nk[j])) {
            uk[u] = ok[i];
            us[3 * u] = os[3 * i]; us[3 * u + 1] = os[3 * i + 1]; us[3 * u + 2] = os[3 * i + 2];
            uc[u] = oc[i];
            uh[u] = oh[i];
            i++;
        } else if (i >= no || nk[j] < ok[i]) {
            uk[u] = nk[j];
            us[3 * u] = 0.0 + ns[3 * j]; us[3 * u + 1] = 0.0 + ns[3 * j + 1]; us[3 * u + 2] = 0.0 + ns[3 * j + 2];
            uc[u] = 0.0 + nc[j];
            uh[u] = NAN;
            new_at[j++] = u;
        } else {
            uk[u] = ok[i];
            us[3 * u] = os[3 * i] + ns[3 * j]; us[3 * u + 1] = os[3 * i + 1] + ns[3 * j + 1];
            us[3 * u + 2] = os[3 * i + 2] + ns[3 * j + 2];
            uc[u] = oc[i] + nc[j];
            uh[u] = oh[i];
            new_at[j++] = u;
            i++;
        }
        u++;
    }
    return u;
}

/* ---- grid Dijkstra -------------------------------------------------------------------------------------- */

/* Cells queued by distance. Every step costs at least 1, so a cell whose distance lies in [k, k + 1) is final once the
 * cells below k are done: bucket k is taken in any order, and a step from it lands in bucket k + 1 or k + 2 (costs 1
 * and sqrt(2) < 2). Four rotating buckets hold the live ones. */
typedef struct {
    int64_t *v;
    int64_t n, cap;
} Bucket;

static int bucket_push(Bucket *b, int64_t v) {
    if (b->n == b->cap) {
        const int64_t cap = b->cap ? 2 * b->cap : 256;
        int64_t *grown = realloc(b->v, (size_t)cap * sizeof(int64_t));
        if (!grown)
            return -1;
        b->v = grown;
        b->cap = cap;
    }
    b->v[b->n++] = v;
    return 0;
}

static int list_push(int64_t **a, int64_t *n, int64_t *cap, int64_t v) {
    if (*n == *cap) {
        const int64_t c = *cap ? 2 * *cap : 1024;
        int64_t *grown = realloc(*a, (size_t)c * sizeof(int64_t));
        if (!grown)
            return -1;
        *a = grown;
        *cap = c;
    }
    (*a)[(*n)++] = v;
    return 0;
}

/* gridgraph.py `cell_graph` searched from nsrc source cells src (flat indices on the (h, w) mask, each starting at
 * init[k] in [0, 1), 0 when init is NULL: GeodesicField's virtual source reaches its targets' cells at their offsets):
 * 4 straight steps of cost 1 and 4 diagonal ones of cost sqrt(2), a diagonal only when both cells it passes beside
 * are on the mask; a step to a distance past `limit` is not taken (scipy's `limit`). dist (h * w, inf on entry) gets
 * each reached cell's distance in cells. Each is the least fl(d(u) + cost) over its neighbours u, as in scipy's
 * Dijkstra: that least value does not depend on the order in which equal or near keys are settled. When out is given
 * the settled cells and their distances are written to out and out_d in settling order; when touched is given, every
 * cell whose dist was set is listed there (the caller restores inf). Returns the number settled, -1 out of memory. */
static int64_t grid_search(const uint8_t *mask, int64_t h, int64_t w, const int64_t *src, const double *init,
                           int64_t nsrc, double limit, double *dist, int64_t *out, double *out_d, int64_t **touched,
                           int64_t *n_touched, int64_t *cap_touched) {
    static const int dr[8] = {0, 1, 1, 1, 0, -1, -1, -1}, dc[8] = {1, 1, 0, -1, -1, -1, 0, 1};
    const double diag = sqrt(2.0);
    Bucket bk[4] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    if (h <= 0 || w <= 0)
        return 0; /* no cells: nothing to settle (calloc of 0 bytes may give NULL) */
    uint8_t *done = calloc((size_t)(h * w), 1);
    int64_t settled = 0, live = 0;
    if (!done)
        return -1;
    for (int64_t k = 0; k < nsrc; k++) {
        const int64_t v = src[k];
        const double d0 = init ? init[k] : 0.0;
        if (!(d0 < dist[v]))
            continue;
        if (touched && dist[v] == INFINITY && list_push(touched, n_touched, cap_touched, v))
            goto oom;
        dist[v] = d0;
        if (bucket_push(&bk[0], v))
            goto oom;
        live++;
    }
    for (int64_t k = 0; live > 0; k++) {
        Bucket *b = &bk[k & 3];
        for (int64_t i = 0; i < b->n; i++) { /* steps from here land in buckets k + 1 and k + 2, never in this one */
            const int64_t v = b->v[i];
            live--;
            if (done[v])
                continue; /* queued again at a smaller distance and settled then */
            done[v] = 1;
            const double dv = dist[v];
            if (out) {
                out[settled] = v;
                out_d[settled] = dv;
            }
            settled++;
            const int64_t r = v / w, c = v % w;
            for (int q = 0; q < 8; q++) {
                const int64_t rr = r + dr[q], cc = c + dc[q];
                if (rr < 0 || rr >= h || cc < 0 || cc >= w || !mask[rr * w + cc])
                    continue;
                const int diagonal = dr[q] != 0 && dc[q] != 0;
                if (diagonal && !(mask[rr * w + c] && mask[r * w + cc]))
                    continue;
                const double nd = dv + (diagonal ? diag : 1.0);
                const int64_t u = rr * w + cc;
                if (nd > limit || !(nd < dist[u]))
                    continue;
                if (touched && dist[u] == INFINITY && list_push(touched, n_touched, cap_touched, u))
                    goto oom;
                dist[u] = nd;
                if (bucket_push(&bk[(int64_t)nd & 3], u))
                    goto oom;
                live++;
            }
        }
        b->n = 0;
    }
    for (int q = 0; q < 4; q++)
        free(bk[q].v);
    free(done);
    return settled;
oom:
    for (int q = 0; q < 4; q++)
        free(bk[q].v);
    free(done);
    return -1;
}

/* `grid_search` from the sources into the caller's dist (h * w, inf on entry). Returns 0, or -1 out of memory. */
int32_t sdv_grid_dijkstra(const uint8_t *mask, int64_t h, int64_t w, const int64_t *src, const double *init,
                          int64_t nsrc, double limit, double *dist) {
    return grid_search(mask, h, w, src, init, nsrc, limit, dist, NULL, NULL, NULL, NULL, NULL) < 0 ? -1 : 0;
}

/* The cells within `limit` of one start cell by `grid_search`, without a full-grid answer: their flat indices into
 * cells and distances (in cells) into d, in settling order; returns their count, -1 out of memory. dist (h * w) is
 * scratch that holds inf on entry and again on return. */
int64_t sdv_grid_reach(const uint8_t *mask, int64_t h, int64_t w, int64_t start, double limit, double *dist,
                       int64_t *cells, double *d) {
    int64_t *touched = NULL, n_touched = 0, cap_touched = 0;
    const int64_t found = grid_search(mask, h, w, &start, NULL, 1, limit, dist, cells, d, &touched, &n_touched,
                                      &cap_touched);
    for (int64_t k = 0; k < n_touched; k++)
        dist[touched[k]] = INFINITY;
    free(touched);
    return found;
}

/* Sort keys (n, nonnegative, none above top's bits) and their idx alongside, by a stable LSD radix sort of 11 bits a
 * pass: equal keys keep their order, as numpy's stable argsort. key2, idx2 and count (2049) are scratch; the sorted
 * arrays end up in *key and *idx (the pointers swap with each pass). */
static void radix_sort(int64_t **key, int64_t **idx, int64_t **key2, int64_t **idx2, int64_t n, uint64_t top,
                       int64_t *count) {
    for (int shift = 0; shift < 64 && (top >> shift) > 0; shift += 11) {
        const int64_t *k = *key, *x = *idx;
        int64_t *k2 = *key2, *x2 = *idx2;
        memset(count, 0, 2049 * sizeof(int64_t));
        for (int64_t i = 0; i < n; i++)
            count[((k[i] >> shift) & 0x7FF) + 1]++;
        for (int b = 0; b < 2048; b++)
            count[b + 1] += count[b];
        for (int64_t i = 0; i < n; i++) {
            const int64_t at = count[(k[i] >> shift) & 0x7FF]++;
            k2[at] = k[i];
            x2[at] = x[i];
        }
        int64_t *t = *key; *key = *key2; *key2 = t;
        t = *idx; *idx = *idx2; *idx2 = t;
    }
}

/* The cell index `sdv_near_any` searches: each point's cell floor((p - o) / h) per axis (o: the points' minimum), the
 * grid's cell counts into dims, and the points and their keys (ix * ny + iy) * nz + iz sorted by key into spts and
 * skeys (`radix_sort`). Returns -1 out of memory, else 0. */
int32_t sdv_cells(const double *pts, int64_t n, double ox, double oy, double oz, double h, double *spts,
                  int64_t *skeys, int64_t *dims) {
    int64_t *c = malloc((size_t)(3 * n + 1) * sizeof(int64_t));
    int64_t *key = malloc((size_t)(n + 1) * sizeof(int64_t)), *key2 = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *idx = malloc((size_t)(n + 1) * sizeof(int64_t)), *idx2 = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *count = malloc(2049 * sizeof(int64_t));
    int32_t status = 0;
    if (!c || !key || !key2 || !idx || !idx2 || !count) {
        status = -1;
        goto done;
    }
    int64_t mx = 0, my = 0, mz = 0;
    for (int64_t i = 0; i < n; i++) {
        c[3 * i] = ifloor((pts[3 * i] - ox) / h);
        c[3 * i + 1] = ifloor((pts[3 * i + 1] - oy) / h);
        c[3 * i + 2] = ifloor((pts[3 * i + 2] - oz) / h);
        if (c[3 * i] > mx) mx = c[3 * i];
        if (c[3 * i + 1] > my) my = c[3 * i + 1];
        if (c[3 * i + 2] > mz) mz = c[3 * i + 2];
    }
    dims[0] = mx + 1;
    dims[1] = my + 1;
    dims[2] = mz + 1;
    int64_t kmax = 0;
    for (int64_t i = 0; i < n; i++) {
        key[i] = (c[3 * i] * dims[1] + c[3 * i + 1]) * dims[2] + c[3 * i + 2];
        idx[i] = i;
        if (key[i] > kmax) kmax = key[i];
    }
    radix_sort(&key, &idx, &key2, &idx2, n, (uint64_t)kmax, count);
    for (int64_t i = 0; i < n; i++) {
        skeys[i] = key[i];
        spts[3 * i] = pts[3 * idx[i]];
        spts[3 * i + 1] = pts[3 * idx[i] + 1];
        spts[3 * i + 2] = pts[3 * idx[i] + 2];
    }
done:
    free(c); free(key); free(key2); free(idx); free(idx2); free(count);
    return status;
}

/* perceive/backproject.py `voxel_stats` without its values: each point's voxel key (floor(p / voxel) + 2^20 per
 * axis, 21 bits each, as `voxel_keys`), the points' order sorted by key (`radix_sort`: equal keys keep their input
 * order, as numpy's stable argsort), and per voxel its key, the start of its run in
 * that order, its point count and its sums, each added from 0.0 in input order as numpy's bincount adds them.
 * Returns the number of voxels, -1 out of memory. */
int64_t sdv_voxel_stats(const double *p, int64_t n, double voxel, int64_t *order, int64_t *uniq, int64_t *starts,
                        double *counts, double *sums) {
    const int64_t off = (int64_t)1 << 20;
    int64_t *key = malloc((size_t)(n + 1) * sizeof(int64_t)), *key2 = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *idx = malloc((size_t)(n + 1) * sizeof(int64_t)), *idx2 = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *count = malloc(2049 * sizeof(int64_t));
    int64_t m = -1;
    if (!key || !key2 || !idx || !idx2 || !count)
        goto done;
    uint64_t all = 0;
    for (int64_t i = 0; i < n; i++) {
        const int64_t kx = ifloor(p[3 * i] / voxel) + off, ky = ifloor(p[3 * i + 1] / voxel) + off;
        const int64_t kz = ifloor(p[3 * i + 2] / voxel) + off;
        key[i] = (int64_t)(((uint64_t)kx << 42) | ((uint64_t)ky << 21) | (uint64_t)kz);
        idx[i] = i;
        all |= (uint64_t)key[i];
    }
    if ((int64_t)all < 0) { /* a key off the 21-bit range (a point some 20 km out): the caller's numpy form */
        m = -2;
        goto done;
    }
    radix_sort(&key, &idx, &key2, &idx2, n, all, count);
    m = 0;
    for (int64_t i = 0; i < n; i++) {
        order[i] = idx[i];
        if (i == 0 || key[i] != key[i - 1]) {
            uniq[m] = key[i];
            starts[m] = i;
            counts[m] = 0.0;
            sums[3 * m] = 0.0; sums[3 * m + 1] = 0.0; sums[3 * m + 2] = 0.0;
            m++;
        }
        const double *q = p + 3 * idx[i];
        counts[m - 1] += 1.0;
        sums[3 * (m - 1)] += q[0]; sums[3 * (m - 1) + 1] += q[1]; sums[3 * (m - 1) + 2] += q[2];
    }
done:
    free(key); free(key2); free(idx); free(idx2); free(count);
    return m;
}

/* suite/observation.py `ObservationBuilder.category_image`: per pixel, segment id s (instance ids 0..inst_n-1, object
 * ids from base) to its row of lut (instance ids first, then objects), the last row for anything else. */
void sdv_category(const int32_t *seg, int64_t n, int64_t inst_n, int64_t base, const int16_t *lut, int64_t n_lut,
                  int16_t *out) {
    const int64_t none = n_lut - 1;
    for (int64_t i = 0; i < n; i++) {
        const int64_t s = seg[i];
        int64_t key = s >= base ? s - base + inst_n : s;
        if (s < 0 || key >= none || (s < base && s >= inst_n))
            key = none;
        out[i] = lut[key];
    }
}

/* Raise `inv_depth` to a lower bound of 1 / the depth (metres along the optical axis) the flat pass will hold at each
 * pixel (0: no bound), from the front-facing triangles of mesh geom g, which that pass draws (for sdv_occlusion_cull).
 * Each triangle is cut to its part beyond the near plane (times 1.001); that convex polygon counts at a pixel whose centre
 * lies inside it by more than EDGE_MARGIN pixels (the rasteriser then covers that pixel), with the depth of the
 * triangle's plane along the ray through the centre (1/z is affine over the image), raised by a relative 1e-5 (1/z
 * times INV_SHRINK: no division per pixel).
 * Triangles reaching the far plane, projecting beyond GUARD pixels, edge-on or back-facing count nowhere.
 * vert/face: MuJoCo's mesh_vert (float32) and mesh_face (vertex numbers within the mesh); vadr/fadr/fnum: per model
 * geom its mesh's first vertex and face and its face count; pos/mat: per model geom its world position and row-major
 * rotation; cam: camera position, right, up and forward axes (12 doubles); fr: near, far, left, right, bottom, top of
 * the near plane (6 doubles); inv_depth: h x w, rows top-down, raised where a triangle bounds it. */
#define EDGE_MARGIN 0.05
#define INV_SHRINK (1.0 / (1.0 + 1e-5))
/* GL transforms and clips in float32: a vertex u pixels off the image lands within about 1e-7 u of where it should,
 * so beyond GUARD pixels that error could reach EDGE_MARGIN / 5: such triangles are left out */
#define GUARD 1e5
/* whether pixel column c's centre lies inside all np edges by the margin (the edges' affine terms along the row) */
static inline int span_inside(const double *a, const double *b, const double *len, int np, int64_t c) {
    for (int k = 0; k < np; k++)
        if (!(a[k] * ((double)c + 0.5) + b[k] > EDGE_MARGIN * len[k]))
            return 0;
    return 1;
}
static void raster_geom(const float *vert, const int32_t *face, const int64_t *vadr, const int64_t *fadr,
                        const int64_t *fnum, const double *pos, const double *mat, int64_t g, const double *cam,
                        const double *fr, int64_t w, int64_t h, double *inv_depth, int64_t *touched) {
    /* touched (optional): rows and columns (first, last row, first, last column) widened to those it raised */
    const double near = fr[0], far = fr[1], left = fr[2], span_x = fr[3] - fr[2], top = fr[5];
    const double span_y = fr[5] - fr[4], zc = near * 1.001;
    const float *V = vert + 3 * vadr[g];
    const int32_t *F = face + 3 * fadr[g];
    const double *P = pos + 3 * g, *R = mat + 9 * g;
    for (int64_t t = 0; t < fnum[g]; t++) {
        double wv[3][3], e[3][3]; /* world and eye (right, up, forward) coordinates */
        int skip = 0, front = 0;
        for (int k = 0; k < 3; k++) {
            const float *v = V + 3 * F[3 * t + k];
            double rel[3];
            for (int j = 0; j < 3; j++) {
                wv[k][j] = P[j] + R[3 * j] * (double)v[0] + R[3 * j + 1] * (double)v[1] + R[3 * j + 2] * (double)v[2];
                rel[j] = wv[k][j] - cam[j];
            }
            for (int a = 0; a < 3; a++)
                e[k][a] = rel[0] * cam[3 + 3 * a] + rel[1] * cam[4 + 3 * a] + rel[2] * cam[5 + 3 * a];
            if (!(e[k][2] < far * 0.999))
                skip = 1;
            front += e[k][2] >= zc;
        }
        if (skip || front == 0)
            continue;
        /* front-facing: MuJoCo's faces wind counter-clockwise seen from outside, and it culls back faces */
        double e1[3], e2[3], nv[3], to[3];
        for (int j = 0; j < 3; j++) {
            e1[j] = wv[1][j] - wv[0][j];
            e2[j] = wv[2][j] - wv[0][j];
            to[j] = cam[j] - wv[0][j];
        }
        nv[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nv[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nv[2] = e1[0] * e2[1] - e1[1] * e2[0];
        const double facing = nv[0] * to[0] + nv[1] * to[1] + nv[2] * to[2];
        const double nlen = sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
        if (!(facing > 1e-6 * nlen * sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2])))
            continue;
        /* the plane in eye coordinates: m . X = dpl, so along the ray X = z (xn, yn, 1): 1/z = m . (xn, yn, 1) / dpl */
        double m3[3];
        for (int a = 0; a < 3; a++)
            m3[a] = nv[0] * cam[3 + 3 * a] + nv[1] * cam[4 + 3 * a] + nv[2] * cam[5 + 3 * a];
        const double dpl = m3[0] * e[0][0] + m3[1] * e[0][1] + m3[2] * e[0][2];
        if (!(fabs(dpl) > 1e-12 * nlen))
            continue;
        /* cut to z >= zc (Sutherland-Hodgman against one plane): at most four vertices, then project */
        double pu[4], pv[4];
        int np = 0;
        for (int k = 0; k < 3 && !skip; k++) {
            const double *a = e[k], *b = e[(k + 1) % 3];
            const int ina = a[2] >= zc, inb = b[2] >= zc;
            double q[2][3];
            int nq = 0;
            if (ina) {
                q[nq][0] = a[0]; q[nq][1] = a[1]; q[nq][2] = a[2]; nq++;
            }
            if (ina != inb) {
                const double s = (zc - a[2]) / (b[2] - a[2]);
                q[nq][0] = a[0] + s * (b[0] - a[0]);
                q[nq][1] = a[1] + s * (b[1] - a[1]);
                q[nq][2] = zc;
                nq++;
            }
            for (int j = 0; j < nq; j++) {
                pu[np] = (q[j][0] * near / q[j][2] - left) / span_x * (double)w;
                pv[np] = (top - q[j][1] * near / q[j][2]) / span_y * (double)h;
                if (!(fabs(pu[np]) < GUARD) || !(fabs(pv[np]) < GUARD))
                    skip = 1;
                np++;
            }
        }
        if (skip || np < 3)
            continue;
        double area = 0.0, vmin = pv[0], vmax = pv[0];
        for (int k = 0; k < np; k++) {
            const int k1 = (k + 1) % np;
            area += pu[k] * pv[k1] - pu[k1] * pv[k];
            vmin = pv[k] < vmin ? pv[k] : vmin;
            vmax = pv[k] > vmax ? pv[k] : vmax;
        }
        if (!(fabs(area) > 2e-3))
            continue;
        const double sgn = area > 0 ? 1.0 : -1.0;
        double len[4];
        for (int k = 0; k < np; k++) {
            const int k1 = (k + 1) % np;
            len[k] = hypot(pu[k1] - pu[k], pv[k1] - pv[k]);
            if (!(len[k] > 0.0))
                skip = 1;
        }
        if (skip)
            continue;
        /* 1/z at pixel (u, v): m . (xn, yn, 1) / dpl with xn, yn the near-plane coordinates over near */
        const double cu = m3[0] * span_x / ((double)w * near * dpl), cv = -m3[1] * span_y / ((double)h * near * dpl);
        const double c0 = (m3[0] * left / near + m3[1] * top / near + m3[2]) / dpl;
        int64_t r0 = (int64_t)ceil(vmin - 0.5), r1 = (int64_t)floor(vmax - 0.5);
        r0 = r0 < 0 ? 0 : r0;
        r1 = r1 > h - 1 ? h - 1 : r1;
        /* along a row each edge's signed distance (times its length) is a u + b: a per edge, b per row */
        double a[4], ia[4];
        for (int k = 0; k < np; k++) {
            a[k] = -(pv[(k + 1) % np] - pv[k]) * sgn;
            ia[k] = a[k] != 0.0 ? 1.0 / a[k] : 0.0;
        }
        for (int64_t r = r0; r <= r1; r++) {
            const double qv = (double)r + 0.5;
            /* the span where all edges clear the margin (estimated, then its ends moved inwards by the exact test: the
             * estimate's rounding can only leave out a pixel, which bounds less), then each pixel of it (inside
             * between its ends by convexity) */
            double b[4], ilo = -1e300, ihi = 1e300;
            for (int k = 0; k < np; k++) {
                const int k1 = (k + 1) % np;
                b[k] = ((pu[k1] - pu[k]) * (qv - pv[k]) + (pv[k1] - pv[k]) * pu[k]) * sgn;
                const double mk = EDGE_MARGIN * len[k];
                if (a[k] > 0.0) {
                    const double x = (mk - b[k]) * ia[k];
                    ilo = x > ilo ? x : ilo;
                } else if (a[k] < 0.0) {
                    const double x = (mk - b[k]) * ia[k];
                    ihi = x < ihi ? x : ihi;
                } else if (!(b[k] > mk)) {
                    ihi = -1e300;
                }
            }
            if (!(ilo < ihi))
                continue;
            int64_t ca = ilo < -1.0 ? 0 : (int64_t)floor(ilo - 0.5);
            int64_t cb = ihi > (double)w ? w - 1 : (int64_t)ceil(ihi - 0.5);
            ca = ca < 0 ? 0 : ca;
            cb = cb > w - 1 ? w - 1 : cb;
            while (ca <= cb && !span_inside(a, b, len, np, ca)) /* the span's ends, by the exact test */
                ca++;
            while (cb >= ca && !span_inside(a, b, len, np, cb))
                cb--;
            if (ca > cb)
                continue;
            if (touched) {
                touched[0] = r < touched[0] ? r : touched[0];
                touched[1] = r > touched[1] ? r : touched[1];
                touched[2] = ca < touched[2] ? ca : touched[2];
                touched[3] = cb > touched[3] ? cb : touched[3];
            }
            double *row = inv_depth + r * w;
            const double base = c0 + cv * qv;
            for (int64_t c = ca; c <= cb; c++) {
                const double inv = (base + cu * ((double)c + 0.5)) * INV_SHRINK;
                row[c] = inv > row[c] ? inv : row[c];
            }
        }
    }
}

/* A box's screen rectangle (inclusive pixel bounds, grown by one pixel each side, inside the image) and its nearest
 * corner's depth; returns 0 when a corner reaches the near plane (undecidable), 2 when it projects off the image. */
static int box_rect(const double *P, const double *R, const double *A, const double *cam, const double *fr, int64_t w,
                    int64_t h, int64_t *rect, double *zmin_out) {
    const double near = fr[0], left = fr[2], span_x = fr[3] - fr[2], span_y = fr[5] - fr[4];
    double zmin = INFINITY, umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
    for (int k = 0; k < 8; k++) {
        const double l0 = A[0] + ((k & 4) ? A[3] : -A[3]);
        const double l1 = A[1] + ((k & 2) ? A[4] : -A[4]);
        const double l2 = A[2] + ((k & 1) ? A[5] : -A[5]);
        double rel[3];
        for (int j = 0; j < 3; j++)
            rel[j] = P[j] + R[3 * j] * l0 + R[3 * j + 1] * l1 + R[3 * j + 2] * l2 - cam[j];
        const double x = rel[0] * cam[3] + rel[1] * cam[4] + rel[2] * cam[5];
        const double y = rel[0] * cam[6] + rel[1] * cam[7] + rel[2] * cam[8];
        const double z = rel[0] * cam[9] + rel[1] * cam[10] + rel[2] * cam[11];
        zmin = z < zmin ? z : zmin;
        if (!(z > near * (1.0 + 1e-6))) {
            *zmin_out = zmin;
            return 0;
        }
        const double u = (x * near / z - left) / span_x * (double)w;
        const double v = (fr[5] - y * near / z) / span_y * (double)h;
        umin = u < umin ? u : umin;
        umax = u > umax ? u : umax;
        vmin = v < vmin ? v : vmin;
        vmax = v > vmax ? v : vmax;
    }
    *zmin_out = zmin;
    if (!(umin > -1e15 && umax < 1e15 && vmin > -1e15 && vmax < 1e15))
        return 0;
    const double c0 = floor(umin) - 1.0, c1 = ceil(umax) + 1.0, r0 = floor(vmin) - 1.0, r1 = ceil(vmax) + 1.0;
    if (c1 < 0.0 || c0 > (double)(w - 1) || r1 < 0.0 || r0 > (double)(h - 1))
        return 2;
    rect[0] = r0 < 0.0 ? 0 : (int64_t)r0;
    rect[1] = r1 > (double)(h - 1) ? h - 1 : (int64_t)r1;
    rect[2] = c0 < 0.0 ? 0 : (int64_t)c0;
    rect[3] = c1 > (double)(w - 1) ? w - 1 : (int64_t)c1;
    return 1;
}

/* Each OCC_TILE x OCC_TILE tile's smallest inverse bound (tile rows t0..t1, columns u0..u1): a tile wholly inside a
 * box's rectangle is read at once (all its pixels lie above a limit exactly when its smallest does). */
#define OCC_TILE 8
static void tiles_min(const double *inv_depth, int64_t w, int64_t h, double *tmin, int64_t tw, int64_t t0, int64_t t1,
                      int64_t u0, int64_t u1) {
    for (int64_t t = t0; t <= t1; t++)
        for (int64_t u = u0; u <= u1; u++)
            tmin[t * tw + u] = INFINITY;
    const int64_t y1 = (t1 + 1) * OCC_TILE < h ? (t1 + 1) * OCC_TILE : h;
    const int64_t x0 = u0 * OCC_TILE, x1 = (u1 + 1) * OCC_TILE < w ? (u1 + 1) * OCC_TILE : w;
    for (int64_t y = t0 * OCC_TILE; y < y1; y++) {
        const double *row = inv_depth + y * w;
        double *trow = tmin + (y / OCC_TILE) * tw;
        for (int64_t x = x0; x < x1; x++) {
            const double v = row[x];
            if (!(v >= trow[x / OCC_TILE]))
                trow[x / OCC_TILE] = v;
        }
    }
}

/* Whether a box (rectangle r: rows r[0]..r[1], columns r[2]..r[3]; nearest corner at depth zmin) lies behind the bound
 * at every pixel of its rectangle by 1 mm + 0.1 % of zmin (a fragment inside the box lies no nearer than that corner).
 * Tiles marked in `stale` (raised since their smallest was taken) are read again first. */
static int box_behind(const double *inv_depth, int64_t w, int64_t h, double *tmin, uint8_t *stale, int64_t tw,
                      const int64_t *r, double zmin) {
    const double lim = 1.0 / (zmin - (1e-3 + 1e-3 * zmin)); /* in 1/z: zmin > near, so positive */
    for (int64_t ty = r[0] / OCC_TILE; ty <= r[1] / OCC_TILE; ty++) {
        const int64_t y0 = ty * OCC_TILE > r[0] ? ty * OCC_TILE : r[0];
        const int64_t y1 = ty * OCC_TILE + OCC_TILE - 1 < r[1] ? ty * OCC_TILE + OCC_TILE - 1 : r[1];
        for (int64_t tx = r[2] / OCC_TILE; tx <= r[3] / OCC_TILE; tx++) {
            const int64_t x0 = tx * OCC_TILE > r[2] ? tx * OCC_TILE : r[2];
            const int64_t x1 = tx * OCC_TILE + OCC_TILE - 1 < r[3] ? tx * OCC_TILE + OCC_TILE - 1 : r[3];
            if (stale[ty * tw + tx]) {
                tiles_min(inv_depth, w, h, tmin, tw, ty, ty, tx, tx);
                stale[ty * tw + tx] = 0;
            }
            if (tmin[ty * tw + tx] > lim)
                continue; /* the whole tile is nearer than the limit, so its part in the rectangle is */
            if (y0 == ty * OCC_TILE && y1 == ty * OCC_TILE + OCC_TILE - 1 && x0 == tx * OCC_TILE &&
                x1 == tx * OCC_TILE + OCC_TILE - 1)
                return 0; /* a whole tile inside the rectangle, and its smallest is not above */
            for (int64_t y = y0; y <= y1; y++) {
                const double *row = inv_depth + y * w;
                for (int64_t x = x0; x <= x1; x++)
                    if (!(row[x] > lim))
                        return 0;
            }
        }
    }
    return 1;
}

typedef struct {
    double z;
    int64_t i;
} occ_order;

static int occ_order_cmp(const void *a, const void *b) {
    const occ_order *p = (const occ_order *)a, *q = (const occ_order *)b;
    if (p->z != q->z)
        return p->z < q->z ? -1 : 1;
    return p->i < q->i ? -1 : (p->i > q->i);
}

/* sim/occlusion.py `OcclusionTest.hidden`: per geom test_ids[i], whether the flat pass may leave it out. The depth
 * bound comes only from geoms that pass draws: first the mesh geoms occ_ids (raster_geom); then, nearest box first,
 * each tested mesh geom cheap to rasterise (OCC_CANDIDATE_PIXELS_PER_TRIANGLE) is tested and, when it must be drawn,
 * raises the bound for the rest; last the other tested geoms. A tested box projecting off the image is left out, and so is one
 * lying behind the bound at every pixel of its rectangle (`box_behind`); boxes reaching the near plane are drawn.
 * aabb: per model geom its box (centre, half sizes) in the geom frame; inv_depth: h x w scratch filled with 0 (no
 * bound) by the caller, kept as 1/depth; out: n_test flags (1 = leave out). Returns -1 when out of memory. */
#define OCC_PIXELS_PER_TRIANGLE 16.0
/* a tested mesh raises the bound when drawn only if its box covers this many pixels a triangle (walls, floors, big
 * plain furniture): rasterising detailed ones cost the test more than the geoms they hid saved (a house's frames:
 * 16 pixels a triangle, 128 and 1024 measured; docs/results.md) */
#define OCC_CANDIDATE_PIXELS_PER_TRIANGLE 128.0
int32_t sdv_occlusion_cull(const float *vert, const int32_t *face, const int64_t *vadr, const int64_t *fadr,
                           const int64_t *fnum, const double *pos, const double *mat, const double *aabb,
                           const int64_t *occ_ids, int64_t n_occ, const int64_t *test_ids, int64_t n_test,
                           const double *cam, const double *fr, int64_t w, int64_t h, double *inv_depth,
                           uint8_t *out) {
    /* a geom whose box covers fewer than OCC_PIXELS_PER_TRIANGLE pixels a triangle (a detailed small object; the whole
     * image for a box reaching the near plane) costs more to rasterise than it can hide: it raises no bound (fewer
     * occluders only draws more) */
    const double image = (double)(w * h);
    for (int64_t i = 0; i < n_occ; i++) {
        const int64_t g = occ_ids[i];
        int64_t r[4];
        double zmin;
        const int kind = box_rect(pos + 3 * g, mat + 9 * g, aabb + 6 * g, cam, fr, w, h, r, &zmin);
        const double px = kind == 1 ? (double)((r[1] - r[0] + 1) * (r[3] - r[2] + 1)) : image;
        if (kind == 2 || px < OCC_PIXELS_PER_TRIANGLE * (double)fnum[g])
            continue;
        raster_geom(vert, face, vadr, fadr, fnum, pos, mat, g, cam, fr, w, h, inv_depth, NULL);
    }
    const int64_t tw = (w + OCC_TILE - 1) / OCC_TILE, th = (h + OCC_TILE - 1) / OCC_TILE;
    double *tmin = (double *)malloc((size_t)(tw * th) * sizeof(double));
    int64_t *rect = (int64_t *)malloc((size_t)(4 * (n_test > 0 ? n_test : 1)) * sizeof(int64_t));
    double *zmin = (double *)malloc((size_t)(n_test > 0 ? n_test : 1) * sizeof(double));
    int *kind = (int *)malloc((size_t)(n_test > 0 ? n_test : 1) * sizeof(int));
    occ_order *order = (occ_order *)malloc((size_t)(n_test > 0 ? n_test : 1) * sizeof(occ_order));
    uint8_t *stale = (uint8_t *)calloc((size_t)(tw * th), 1);
    if (!tmin || !rect || !zmin || !kind || !order || !stale) {
        free(tmin), free(rect), free(zmin), free(kind), free(order), free(stale);
        return -1;
    }
    tiles_min(inv_depth, w, h, tmin, tw, 0, th - 1, 0, tw - 1);
    int64_t n_cand = 0;
    for (int64_t i = 0; i < n_test; i++) {
        const int64_t g = test_ids[i];
        kind[i] = box_rect(pos + 3 * g, mat + 9 * g, aabb + 6 * g, cam, fr, w, h, rect + 4 * i, zmin + i);
        out[i] = kind[i] == 2;
        if (kind[i] != 1 || fnum[g] <= 0)
            continue;
        const int64_t *r = rect + 4 * i;
        if ((double)((r[1] - r[0] + 1) * (r[3] - r[2] + 1)) >= OCC_CANDIDATE_PIXELS_PER_TRIANGLE * (double)fnum[g]) {
            order[n_cand].z = zmin[i]; /* a candidate occluder: decided below, in depth order */
            order[n_cand].i = i;
            n_cand++;
        }
    }
    qsort(order, (size_t)n_cand, sizeof(occ_order), occ_order_cmp);
    for (int64_t k = 0; k < n_cand; k++) {
        const int64_t i = order[k].i, g = test_ids[i];
        kind[i] = -1; /* decided here: the last loop passes it over */
        if (box_behind(inv_depth, w, h, tmin, stale, tw, rect + 4 * i, zmin[i])) {
            out[i] = 1;
            continue;
        }
        /* drawn: its triangles bound the depth behind it; the tiles of the rows and columns they reached are read
         * again when a box test next reads them */
        int64_t t[4] = {h, -1, w, -1};
        raster_geom(vert, face, vadr, fadr, fnum, pos, mat, g, cam, fr, w, h, inv_depth, t);
        for (int64_t ty = t[0] / OCC_TILE; t[1] >= 0 && ty <= t[1] / OCC_TILE; ty++)
            memset(stale + ty * tw + t[2] / OCC_TILE, 1, (size_t)(t[3] / OCC_TILE - t[2] / OCC_TILE + 1));
    }
    for (int64_t i = 0; i < n_test; i++)
        if (kind[i] == 1)
            out[i] = box_behind(inv_depth, w, h, tmin, stale, tw, rect + 4 * i, zmin[i]);
    free(tmin), free(rect), free(zmin), free(kind), free(order), free(stale);
    return 0;
}

/* sim/render.py `SceneRenderer._decode_table`: which of the 256 red-channel id codes an image shows (n pixels,
 * `stride` bytes apart): seen[c] = 1 for each code c present, as np.bincount(codes) > 0. */
void sdv_codes_seen(const uint8_t *codes, int64_t n, int64_t stride, uint8_t *seen) {
    memset(seen, 0, 256);
    for (int64_t i = 0; i < n; i++)
        seen[codes[i * stride]] = 1;
}

/* sim/render.py `SceneRenderer._render`: per pixel of an id-colour image (h rows of w pixels, `channels` bytes each,
 * rows bottom-up when `flip`, as GL reads them), table[its red code] into out (h x w int32, rows top-down). */
void sdv_code_lookup(const uint8_t *pix, int64_t h, int64_t w, int64_t channels, int32_t flip, const int32_t *table,
                     int32_t *out) {
    for (int64_t r = 0; r < h; r++) {
        const uint8_t *src = pix + (flip ? h - 1 - r : r) * w * channels;
        int32_t *dst = out + r * w;
        for (int64_t c = 0; c < w; c++)
            dst[c] = table[src[c * channels]];
    }
}

/* sim/render.py `SceneRenderer.outside_view`: per geom (centre xpos, bounding radius rbound), whether its sphere grown
 * by 1 mm lies wholly outside one plane of the view: before the near plane, beyond the far one, or off a side whose
 * slope (c = s z on it) is s with unit normal scale 1 / nrm. cam: position, right, up, forward (12 doubles, as
 * sdv_occlusion_cull reads them); planes:
 * near, far, then s_hi, nrm_hi, s_lo, nrm_lo for x, then for y (10 doubles). The same double operations in the same
 * order as the Python form (each dot product summed left to right). out: n flags (1 = outside, radius > 0). */
void sdv_frustum_out(const double *xpos, const double *rbound, int64_t n, const double *cam, const double *planes,
                     uint8_t *out) {
    const double near = planes[0], far = planes[1];
    for (int64_t i = 0; i < n; i++) {
        const double p0 = xpos[3 * i] - cam[0], p1 = xpos[3 * i + 1] - cam[1], p2 = xpos[3 * i + 2] - cam[2];
        const double x = p0 * cam[3] + p1 * cam[4] + p2 * cam[5];
        const double y = p0 * cam[6] + p1 * cam[7] + p2 * cam[8];
        const double z = p0 * cam[9] + p1 * cam[10] + p2 * cam[11];
        const double rb = rbound[i], r_out = rb + 1e-3;
        int o = (z + r_out < near) | (z - r_out > far);
        const double cs[2] = {x, y};
        for (int k = 0; k < 2; k++) {
            const double *q = planes + 2 + 4 * k;
            o |= (cs[k] - q[0] * z) / q[1] > r_out;
            o |= (q[2] * z - cs[k]) / q[3] > r_out;
        }
        out[i] = (uint8_t)(o && rb > 0.0);
    }
}

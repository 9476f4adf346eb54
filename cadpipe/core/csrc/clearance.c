/* Where tubes come near themselves or each other: the segment pairs of a batch of paths
 * that lie within reach of each other although they are not neighbours along the path.
 *
 * Two questions share one walk of a box tree of the segments (widened by their reach)
 * against itself, which drops a node pair once its boxes are apart or once no pair
 * under it can count; leaf pairs closer than their reaches' sum count:
 *
 * - folds (cadpipe.geometry.clearance): two segments of one tube, the stretch of path
 *   between them turning by a right angle or more (along a stretch that turns less the
 *   distance between two points grows with their separation);
 * - crossings (cadpipe.geometry.splice): segments of different pieces of a chain, at
 *   least pi/2 times their reaches' sum apart along the chain (nearer ones are
 *   neighbours across a junction).
 */
#include "native.h"
#include "distance.h"
#include "tree.h"

enum { FOLDS, CROSSINGS };

typedef struct {
    int mode;
    int64_t n;
    const double *start, *seg, *reach;
    const int64_t *group;         /* tube (folds) or piece (crossings) of each column */
    /* folds */
    const npy_bool *usable, *closed;
    const int64_t *next;
    const double *turning, *total;
    double right_angle;
    /* crossings */
    const double *arc, *length;
    double chain_length;
    /* the tree: per node its box and (crossings) its least reach */
    int depth;
    double *lo, *hi, *thin;
} Segments;

/* The columns [lo, hi] under a node (hi < lo: none). */
static inline void node_columns(const Segments *g, int64_t node, int64_t *lo, int64_t *hi)
{
    int64_t first, count;
    tree_leaves(node, g->depth, &first, &count);
    *lo = first;
    *hi = first + count - 1 < g->n - 1 ? first + count - 1 : g->n - 1;
}

/* Whether no pair of columns of nodes a (columns la..ha) and b (lb..hb, la <= lb) can
 * count. */
static inline int nothing_counts(const Segments *g, int64_t a, int64_t b, int64_t la, int64_t ha,
                                 int64_t lb, int64_t hb)
{
    int64_t ta = g->group[la], tb = g->group[hb];
    int one = ta == g->group[ha] && tb == g->group[lb];   /* each node within one group */
    if (g->mode == FOLDS) {
        if (!one)
            return 0;
        if (ta != tb)
            return 1;
        double most = g->turning[ha > hb ? ha : hb] - g->turning[la];
        double least = lb > ha ? g->turning[lb] - g->turning[ha] : 0.0;
        return most < g->right_angle ||
               (g->closed[ta] && g->total[ta] - least < g->right_angle);
    }
    if (one && ta == tb)
        return 1;
    /* the farthest two of their segments lie along the chain nearer than any pair counts */
    double farthest = g->arc[hb] + g->length[hb] - g->arc[la];
    return farthest < 0.5 * M_PI * (g->thin[a] + g->thin[b]);
}

static inline int boxes_apart(const Segments *g, int64_t a, int64_t b)
{
    for (int r = 0; r < 3; r++)
        if (g->lo[3 * a + r] > g->hi[3 * b + r] || g->lo[3 * b + r] > g->hi[3 * a + r])
            return 1;
    return 0;
}

static inline double segments_gap(const Segments *g, int64_t i, int64_t j)
{
    double s, t;
    V3 p = v3_at(g->start + 3 * i), u = v3_at(g->seg + 3 * i);
    V3 q = v3_at(g->start + 3 * j), v = v3_at(g->seg + 3 * j);
    segments_closest(p, u, q, v, &s, &t);
    return sqrt(v3_norm2(v3_sub(v3_add(p, v3_scale(u, s)), v3_add(q, v3_scale(v, t)))));
}

/* Growable (i, j, distance) output. */
typedef struct {
    int64_t *i, *j;
    double *d;
    int64_t count, room;
} Found;

static int found_push(Found *f, int64_t i, int64_t j, double d)
{
    if (f->count == f->room) {
        int64_t room = f->room ? 2 * f->room : 1024;
        int64_t *ni = realloc(f->i, room * sizeof *ni);
        if (!ni)
            return 0;
        f->i = ni;
        int64_t *nj = realloc(f->j, room * sizeof *nj);
        if (!nj)
            return 0;
        f->j = nj;
        double *nd = realloc(f->d, room * sizeof *nd);
        if (!nd)
            return 0;
        f->d = nd;
        f->room = room;
    }
    f->i[f->count] = i, f->j[f->count] = j, f->d[f->count] = d;
    f->count++;
    return 1;
}

/* The piece pairs found so far (crossings), an open-addressing set of p * groups + q. */
typedef struct {
    int64_t *keys;
    int64_t size, count;
} PairSet;

static int set_has(const PairSet *s, int64_t key)
{
    for (int64_t at = (key * 0x9e3779b97f4a7c15ull) & (s->size - 1);; at = (at + 1) & (s->size - 1)) {
        if (s->keys[at] == key)
            return 1;
        if (s->keys[at] < 0)
            return 0;
    }
}

static int set_add(PairSet *s, int64_t key)
{
    if (2 * (s->count + 1) > s->size) {
        PairSet bigger = {malloc(sizeof(int64_t) * 2 * s->size), 2 * s->size, 0};
        if (!bigger.keys)
            return 0;
        memset(bigger.keys, 0xff, sizeof(int64_t) * bigger.size);
        for (int64_t k = 0; k < s->size; k++)
            if (s->keys[k] >= 0)
                set_add(&bigger, s->keys[k]);
        free(s->keys);
        *s = bigger;
    }
    int64_t at = (key * 0x9e3779b97f4a7c15ull) & (s->size - 1);
    while (s->keys[at] >= 0 && s->keys[at] != key)
        at = (at + 1) & (s->size - 1);
    if (s->keys[at] < 0) {
        s->keys[at] = key;
        s->count++;
    }
    return 1;
}

/* The walk, into ``found`` (folds: every column pair; crossings: one column pair per
 * piece pair, each piece pair in ``seen``). Stops once a group has more than ``budget``
 * pairs (returned, else -1); 0 in ``*ok`` when memory ran out. */
static int64_t walk_pairs(Segments *g, int64_t budget, Found *found, PairSet *seen, int *ok)
{
    int64_t n = g->n, groups = 0;
    for (int64_t k = 0; k < n; k++)
        groups = g->group[k] + 1 > groups ? g->group[k] + 1 : groups;
    int64_t leaves = (int64_t)1 << g->depth, first_leaf = leaves - 1;
    int64_t *stack = malloc(sizeof(int64_t) * 2 * (4 * (int64_t)g->depth + 8));
    int64_t *spent = calloc(groups ? groups : 1, sizeof(int64_t));
    int64_t over = -1;
    *ok = stack && spent;
    if (*ok) {
        for (int64_t k = 0; k < leaves; k++) {          /* leaf boxes: segment +- reach */
            double *lo = g->lo + 3 * (first_leaf + k), *hi = g->hi + 3 * (first_leaf + k);
            for (int r = 0; r < 3; r++) {
                if (k < n) {
                    double a = g->start[3 * k + r], b = a + g->seg[3 * k + r];
                    lo[r] = (a < b ? a : b) - g->reach[k];
                    hi[r] = (a < b ? b : a) + g->reach[k];
                } else {
                    lo[r] = INFINITY, hi[r] = -INFINITY;
                }
            }
            g->thin[first_leaf + k] = k < n ? g->reach[k] : INFINITY;
        }
        for (int64_t k = first_leaf - 1; k >= 0; k--) {
            for (int r = 0; r < 3; r++) {
                g->lo[3 * k + r] = cp_min(g->lo[3 * (2 * k + 1) + r], g->lo[3 * (2 * k + 2) + r]);
                g->hi[3 * k + r] = cp_max(g->hi[3 * (2 * k + 1) + r], g->hi[3 * (2 * k + 2) + r]);
            }
            g->thin[k] = cp_min(g->thin[2 * k + 1], g->thin[2 * k + 2]);
        }
    }
    int64_t top = 0;
    if (*ok && n > 1) {
        stack[0] = 0, stack[1] = 0;
        top = 1;
    }
    while (top && *ok && over < 0) {
        top--;
        int64_t a = stack[2 * top], b = stack[2 * top + 1], la, ha, lb, hb;
        node_columns(g, a, &la, &ha);
        node_columns(g, b, &lb, &hb);
        if (ha < la || hb < lb || (a != b && boxes_apart(g, a, b)) ||
            nothing_counts(g, a, b, la, ha, lb, hb))
            continue;
        int64_t ga = g->group[la], gb = g->group[lb];
        if (g->mode == CROSSINGS && ga == g->group[ha] && gb == g->group[hb] &&
            set_has(seen, ga * groups + gb))
            continue;                               /* these two pieces already cross */
        if (a >= first_leaf && b >= first_leaf) {
            int64_t i = la, j = lb;
            int same = g->group[i] == g->group[j];
            if (i == j || (g->mode == FOLDS ? !same : same))
                continue;
            double d = segments_gap(g, i, j);
            if (!(d < g->reach[i] + g->reach[j]))
                continue;
            if (g->mode == FOLDS) {
                if (!g->usable[i] || !g->usable[j] || g->next[i] == j || g->next[j] == i)
                    continue;
                *ok = found_push(found, i, j, d);
                if (++spent[g->group[i]] > budget)
                    over = g->group[i];
            } else {
                double apart = g->arc[j] - g->arc[i];
                if (g->chain_length > 0.0)                /* a closed chain: either way */
                    apart = cp_min(apart, g->chain_length - apart);
                int64_t earlier = g->arc[i] < g->arc[j] ? i : j;
                if (apart - g->length[earlier] >= 0.5 * M_PI * (g->reach[i] + g->reach[j])) {
                    *ok = found_push(found, i, j, d) && set_add(seen, ga * groups + gb);
                    if (++spent[0] > budget)
                        over = 0;
                }
            }
            continue;
        }
        if (a == b) {                               /* a node against itself */
            int64_t c = 2 * a + 1;
            stack[2 * top] = c, stack[2 * top + 1] = c + 1;
            stack[2 * top + 2] = c + 1, stack[2 * top + 3] = c + 1;
            stack[2 * top + 4] = c, stack[2 * top + 5] = c;
            top += 3;
            continue;
        }
        /* the larger node's children (a leaf stays), in column order */
        double size_a = 0.0, size_b = 0.0;
        for (int r = 0; r < 3; r++) {
            size_a += g->hi[3 * a + r] - g->lo[3 * a + r];
            size_b += g->hi[3 * b + r] - g->lo[3 * b + r];
        }
        if (b >= first_leaf || (a < first_leaf && size_a >= size_b)) {
            stack[2 * top] = 2 * a + 2, stack[2 * top + 1] = b;
            stack[2 * top + 2] = 2 * a + 1, stack[2 * top + 3] = b;
        } else {
            stack[2 * top] = a, stack[2 * top + 1] = 2 * b + 2;
            stack[2 * top + 2] = a, stack[2 * top + 3] = 2 * b + 1;
        }
        top += 2;
    }
    free(stack), free(spent);
    return over;
}

/* Run the walk over ``g`` (its tree allocated here) and return (i, j, distance, over). */
static PyObject *near_pairs(Segments *g, int64_t budget)
{
    g->depth = tree_depth(g->n > 0 ? g->n : 1);
    int64_t nodes = 2 * ((int64_t)1 << g->depth) - 1;
    g->lo = malloc(sizeof(double) * 3 * nodes);
    g->hi = malloc(sizeof(double) * 3 * nodes);
    g->thin = malloc(sizeof(double) * nodes);
    PairSet seen = {malloc(sizeof(int64_t) * 64), 64, 0};
    Found found = {NULL, NULL, NULL, 0, 0};
    int ok = g->lo && g->hi && g->thin && seen.keys;
    int64_t over = -1;
    if (ok) {
        memset(seen.keys, 0xff, sizeof(int64_t) * seen.size);
        Py_BEGIN_ALLOW_THREADS
        over = walk_pairs(g, budget, &found, &seen, &ok);
        Py_END_ALLOW_THREADS
    }
    free(g->lo), free(g->hi), free(g->thin), free(seen.keys);
    PyObject *result = NULL;
    if (ok) {
        npy_intp dims[1] = {found.count};
        PyArrayObject *i = cp_new(1, dims, NPY_INT64), *j = cp_new(1, dims, NPY_INT64);
        PyArrayObject *d = cp_new(1, dims, NPY_FLOAT64);
        if (i && j && d) {
            if (found.count) {
                memcpy(PyArray_DATA(i), found.i, found.count * sizeof(int64_t));
                memcpy(PyArray_DATA(j), found.j, found.count * sizeof(int64_t));
                memcpy(PyArray_DATA(d), found.d, found.count * sizeof(double));
            }
            result = Py_BuildValue("NNNL", i, j, d, (long long)over);
        } else {
            Py_XDECREF(i), Py_XDECREF(j), Py_XDECREF(d);
        }
    } else {
        PyErr_NoMemory();
    }
    free(found.i), free(found.j), free(found.d);
    return result;
}

/* fold_pairs(start (N, 3), seg (N, 3), reach (N,), usable (N,) bool, tube (N,), next (N,),
 * turning (N,) cumulative, closed (T,) bool, total (T,), right_angle, budget)
 * -> (i, j, distance, over): every column pair i < j of one tube, both real segments and
 * not neighbours, closer than their reaches, the path between them turning by at least
 * ``right_angle`` (around a closed tube, either way), in no particular order. The walk
 * stops once a tube has more than ``budget`` pairs (``over``: that tube, else -1). */
KERNEL(fold_pairs)
{
    CP_NARGS(11);
    IN_F64(0, start, 2);
    IN_F64(1, seg, 2);
    IN_F64(2, reach, 1);
    IN_BOOL(3, usable, 1);
    IN_I64(4, tube, 1);
    IN_I64(5, next, 1);
    IN_F64(6, turning, 1);
    IN_BOOL(7, closed, 1);
    IN_F64(8, total, 1);
    IN_DOUBLE(9, right_angle);
    IN_LONG(10, budget);
    Segments g = {FOLDS, start.shape[0], F64(start), F64(seg), F64(reach), I64(tube),
                  BOOL(usable), BOOL(closed), I64(next), F64(turning), F64(total),
                  right_angle};
    return near_pairs(&g, budget);
}

/* crossing_pairs(start (N, 3), seg (N, 3), reach (N,), piece (N,), arc (N,), length (N,),
 * chain_length, budget) -> (i, j, distance, over): column pairs i < j of different pieces
 * closer than their reaches, at least pi/2 times that sum apart along the chain beyond
 * the earlier one's length (``chain_length`` > 0: a closed chain, apart either way);
 * one pair per pair of pieces. ``over`` is 0 once more than ``budget`` were found. */
KERNEL(crossing_pairs)
{
    CP_NARGS(8);
    IN_F64(0, start, 2);
    IN_F64(1, seg, 2);
    IN_F64(2, reach, 1);
    IN_I64(3, piece, 1);
    IN_F64(4, arc, 1);
    IN_F64(5, length, 1);
    IN_DOUBLE(6, chain_length);
    IN_LONG(7, budget);
    Segments g = {CROSSINGS, start.shape[0], F64(start), F64(seg), F64(reach), I64(piece)};
    g.arc = F64(arc), g.length = F64(length), g.chain_length = chain_length;
    return near_pairs(&g, budget);
}

static PyMethodDef clearance_methods[] = {
    ENTRY(fold_pairs, "(start, seg, reach, usable, tube, next, turning, closed, total,"
                      " right_angle, budget) -> (i, j, distance, over)"),
    ENTRY(crossing_pairs, "(start, seg, reach, piece, arc, length, chain_length, budget)"
                          " -> (i, j, distance, over)"),
    END_ENTRIES};

/* jaxflex FMU: the cell's outputs at the communication point (resource format 3).
 *
 * Cup reactions and stresses are linear in the modal state and the base acceleration,
 * y = Q q + V v + A a + y_rest (jaxflex._outputs: y_rest = -S g, the exact outputs of the part
 * at rest under gravity); they are evaluated when read, from m->q, m->v and m->a_now. The cup
 * utilisation and the von Mises stress are those of jaxflex._loads; the distance of a point
 * (at rest under gravity, moved by the path m->pos and its displacement) to the nearest
 * obstacle is that of jaxflex._cell, less half the part's thickness (its skins). SI units.
 *
 * Obstacle records of JXF_OBSTACLE_VALUES values: a kind code, then the kind's values. The
 * kinds are one table, fmu/obstacles.py, which jxf_config.h carries as JXF_OBSTACLE_* macros:
 * box (centre 3, half edges 3, rotation 9 row-major: the box axes are its columns),
 * half_space (unit normal 3, offset: the solid is normal . x <= offset), triangle (corners
 * 3 x 3). A record of another kind is refused when the resource is loaded
 * (jxf_check_obstacles).
 */
#include <math.h>

#include "jxf_blocks.h"
#include "jxf_cell.h"
#include "jxf_config.h"
#include "jxf_model.h"

/* every kind of the table is implemented below: a kind added there must be added here */
#if JXF_OBSTACLE_KIND_COUNT != 3 || !defined(JXF_OBSTACLE_BOX) || \
    !defined(JXF_OBSTACLE_HALF_SPACE) || !defined(JXF_OBSTACLE_TRIANGLE)
#error "the obstacle kinds of fmu/obstacles.py differ from those jxf_cell.c implements"
#endif

int jxf_check_obstacles(const jxf_model *m, const char *name) {
    static const int codes[] = JXF_OBSTACLE_CODES;
    int o, k, known;
    for (o = 0; o < m->n_obstacles; ++o) {
        const double code = m->obstacles[JXF_OBSTACLE_VALUES * (size_t)o];
        for (known = 0, k = 0; k < JXF_OBSTACLE_KIND_COUNT; ++k) known |= code == codes[k];
        if (!known) {
            jxf_log(m, JXF_LOG_ERROR, "'%s': obstacle record %d has the kind code %g; this FMU "
                    "reads " JXF_OBSTACLE_ALLOWED, name, o, code);
            return -1;
        }
    }
    return 0;
}

/* row `r` of the output block (Q, V, A, at rest; a turning part: A_rot) at the current
 * state: Q q + V v + A (a - g_b) + A_rot b + y_rest (a part that does not turn: g_b = 0,
 * b = 0; a turning part: y_rest = 0, its q the total state, gravity in its forcing) */
static double linear_output(const jxf_model *m, const double *q_map, const double *v_map,
                            const double *a_map, const double *at_rest, const double *rot_map,
                            size_t r) {
    const int M = m->n_modes;
    const double *qr = q_map + r * (size_t)M, *vr = v_map + r * (size_t)M, *ar = a_map + 3 * r;
    double y = at_rest[r];
    int i;
    for (i = 0; i < M; ++i) y += qr[i] * m->q[i] + vr[i] * m->v[i];
    for (i = 0; i < 3; ++i) y += ar[i] * (m->a_now[i] - m->g_now[i]);
    if (m->turning)
        for (i = 0; i < 9; ++i) y += rot_map[9 * r + i] * m->b_now[i];
    return y;
}

static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

void jxf_cup_reaction(const jxf_model *m, int c, double y[6]) {
    int k;
    for (k = 0; k < 6; ++k)
        y[k] = linear_output(m, m->cup_q, m->cup_v, m->cup_a, m->cup_rest, m->cup_rot,
                             6 * (size_t)c + (size_t)k);
}

double jxf_cup_utilisation(const jxf_model *m, int c) {
    const double *n = m->cup_normal + 3 * c;
    const double mu = m->cup_friction[c], r = m->cup_radius[c];
    double y[6], pull, twist, shear[3], peel[3];
    int k;
    jxf_cup_reaction(m, c, y);
    pull = y[0] * n[0] + y[1] * n[1] + y[2] * n[2];
    twist = y[3] * n[0] + y[4] * n[1] + y[5] * n[2];
    for (k = 0; k < 3; ++k) {
        shear[k] = y[k] - pull * n[k];
        peel[k] = y[3 + k] - twist * n[k];
    }
    return m->cup_safety / m->cup_holding[c] *
           ((pull > 0.0 ? pull : 0.0) + norm3(shear) / mu + 4.0 * norm3(peel) / r +
            1.5 * fabs(twist) / (mu * r));
}

double jxf_von_mises(const jxf_model *m, int s) {
    double y[6], sq;
    int k;
    for (k = 0; k < 6; ++k)
        y[k] = linear_output(m, m->stress_q, m->stress_v, m->stress_a, m->stress_rest,
                             m->stress_rot, 6 * (size_t)s + (size_t)k);
    sq = 0.5 * ((y[0] - y[1]) * (y[0] - y[1]) + (y[1] - y[2]) * (y[1] - y[2]) +
                (y[2] - y[0]) * (y[2] - y[0])) +
         3.0 * (y[3] * y[3] + y[4] * y[4] + y[5] * y[5]);
    return sqrt(sq > 0.0 ? sq : 0.0);
}

static double dot3(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* g = (p - q) / |p - q| (zero where p = q): the unit vector from q to p. */
static void direction(const double p[3], const double q[3], double distance, double g[3]) {
    int i;
    for (i = 0; i < 3; ++i) g[i] = distance > 0.0 ? (p[i] - q[i]) / distance : 0.0;
}

/* Signed distance to a box: negative inside (minus the distance to the nearest face). With
 * `g`, a subgradient there (the distance is convex): outwards from the nearest point outside,
 * the nearest face's normal inside. */
static double box_distance(const double *rec, const double p[3], double *g) {
    const double *centre = rec, *half = rec + 3, *rot = rec + 6;
    double local[3], outside = 0.0, depth = -HUGE_VAL, out[3] = {0.0, 0.0, 0.0}, d;
    int i, deepest = 0;
    for (i = 0; i < 3; ++i) { /* local_i = column i of the rotation . (p - centre) */
        local[i] = rot[i] * (p[0] - centre[0]) + rot[3 + i] * (p[1] - centre[1]) +
                   rot[6 + i] * (p[2] - centre[2]);
    }
    for (i = 0; i < 3; ++i) {
        d = fabs(local[i]) - half[i];
        if (d > 0.0) outside += d * d;
        if (d > depth) depth = d, deepest = i;
    }
    d = outside > 0.0 ? sqrt(outside) : depth;
    if (g == NULL) return d;
    for (i = 0; i < 3; ++i) { /* in the box's axes, then turned to the cell's */
        const double sign = local[i] < 0.0 ? -1.0 : 1.0, gap = fabs(local[i]) - half[i];
        if (outside > 0.0)
            out[i] = gap > 0.0 ? sign * gap / d : 0.0;
        else
            out[i] = i == deepest ? sign : 0.0;
    }
    for (i = 0; i < 3; ++i) g[i] = rot[3 * i] * out[0] + rot[3 * i + 1] * out[1] + rot[3 * i + 2] * out[2];
    return d;
}

/* Distance to a triangle (Ericson, Real-Time Collision Detection, 5.1.5); with `g`, the unit
 * vector from the nearest point of the triangle (zero on it). */
static double triangle_distance(const double *rec, const double p[3], double *g) {
    const double *a = rec, *b = rec + 3, *c = rec + 6;
    double ab[3], ac[3], ap[3], bp[3], cp[3], q[3], d1, d2, d3, d4, d5, d6, va, vb, vc, v, w;
    double gap[3], distance;
    int i;
    for (i = 0; i < 3; ++i) {
        ab[i] = b[i] - a[i];
        ac[i] = c[i] - a[i];
        ap[i] = p[i] - a[i];
        bp[i] = p[i] - b[i];
        cp[i] = p[i] - c[i];
    }
    d1 = dot3(ab, ap), d2 = dot3(ac, ap), d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d1 <= 0.0 && d2 <= 0.0) {
        for (i = 0; i < 3; ++i) q[i] = a[i];
    } else if (d3 >= 0.0 && d4 <= d3) {
        for (i = 0; i < 3; ++i) q[i] = b[i];
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        v = d1 / (d1 - d3);
        for (i = 0; i < 3; ++i) q[i] = a[i] + v * ab[i];
    } else if (d6 >= 0.0 && d5 <= d6) {
        for (i = 0; i < 3; ++i) q[i] = c[i];
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        w = d2 / (d2 - d6);
        for (i = 0; i < 3; ++i) q[i] = a[i] + w * ac[i];
    } else if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (i = 0; i < 3; ++i) q[i] = b[i] + w * (c[i] - b[i]);
    } else {
        const double denom = 1.0 / (va + vb + vc);
        v = vb * denom, w = vc * denom;
        for (i = 0; i < 3; ++i) q[i] = a[i] + v * ab[i] + w * ac[i];
    }
    for (i = 0; i < 3; ++i) gap[i] = p[i] - q[i];
    distance = norm3(gap);
    if (g != NULL) direction(p, q, distance, g);
    return distance;
}

/* Distance of p to obstacle record `rec` (its kind code first) and, with `g`, a
 * subgradient of it at p: the distance is convex for every kind, so d(p') >= d(p) +
 * g . (p' - p) everywhere. */
static double obstacle_distance(const double *rec, const double p[3], double *g) {
    switch ((int)rec[0]) { /* the codes are checked when the resource is loaded */
        case JXF_OBSTACLE_BOX:
            return box_distance(rec + 1, p, g);
        case JXF_OBSTACLE_HALF_SPACE:
            if (g != NULL) g[0] = rec[1], g[1] = rec[2], g[2] = rec[3];
            return dot3(rec + 1, p) - rec[4];
        case JXF_OBSTACLE_TRIANGLE:
            return triangle_distance(rec + 1, p, g);
        default:
            if (g != NULL) g[0] = g[1] = g[2] = 0.0;
            return HUGE_VAL;
    }
}

/* The distance of the point at p (cell coordinates) to the nearest obstacle, less half the
 * part's thickness (its skins), m. */
static double point_distance(const jxf_model *m, const double p[3]) {
    double best = HUGE_VAL;
    int o;
    for (o = 0; o < m->n_obstacles; ++o) {
        const double d = obstacle_distance(m->obstacles + JXF_OBSTACLE_VALUES * (size_t)o, p, NULL);
        best = d < best ? d : best;
    }
    return best - m->half_thickness;
}

/* The coordinates of the shapes' rows that place the points, into x (M + R): a part that
 * does not turn, those of its displacement (m->coords: q, a); a turning part, the whole
 * elastic displacement (the sag in the current pose included): q the total modal state,
 * a_O - g_b and b (jaxflex._turning_collision). */
static const double *position_coords(const jxf_model *m, double *x) {
    int i;
    if (!m->turning) return m->coords;
    for (i = 0; i < m->n_modes; ++i) x[i] = m->q[i];
    for (i = 0; i < m->n_static; ++i)
        x[m->n_modes + i] = i < 3 ? m->a_now[i] - m->g_now[i] : m->b_now[i - 3];
    return x;
}

/* Where point k with elastic displacement u is (cell coordinates, m): a part that does not
 * turn, its position at rest under gravity moved by the path m->pos and u; a turning part,
 * c + s + R (x_k - c + u), the pivot c moved by the path s, R the orientation. */
static void place(const jxf_model *m, int k, const double u[3], double p[3]) {
    double local[3];
    int c;
    if (!m->turning) {
        for (c = 0; c < 3; ++c) p[c] = m->rest_points[3 * (size_t)k + c] + m->pos[c] + u[c];
        return;
    }
    for (c = 0; c < 3; ++c) local[c] = m->points[3 * (size_t)k + c] - m->pivot[c] + u[c];
    for (c = 0; c < 3; ++c)
        p[c] = m->pivot[c] + m->pos[c] + m->rot_now[3 * c] * local[0] +
               m->rot_now[3 * c + 1] * local[1] + m->rot_now[3 * c + 2] * local[2];
}

/* Scratch of the distances (m->blocks.cell_work): the blocks' bounds of |u| (nB) and of
 * the distance (nB), a block's displacements (3 largest) and distances (largest), the
 * coordinates and their magnitudes (2 (M + R)). */
typedef struct {
    double *reach, *lower, *u, *d, *x, *magnitude;
} cell_scratch;

static cell_scratch scratch_of(const jxf_model *m) {
    const jxf_blocks *b = &m->blocks;
    const size_t nB = (size_t)b->count, L = (size_t)b->largest;
    cell_scratch w;
    w.reach = b->cell_work;
    w.lower = w.reach + nB;
    w.u = w.lower + nB;
    w.d = w.u + 3 * L;
    w.x = w.d + L;
    w.magnitude = w.x + (m->n_modes + m->n_static);
    return w;
}

/* The distances of block B's members (slot order) into w->d for the coordinates x; their
 * number is returned. */
static int block_distances(const jxf_model *m, int block, const double *x,
                           const cell_scratch *w) {
    const jxf_blocks *b = &m->blocks;
    const int first = b->start[block], size = b->start[block + 1] - first;
    const double *values = w->u;
    double u[3], p[3];
    int s;
    if (m->turning)
        (void)jxf_block_combine(m, block, x, w->u);
    else
        values = jxf_block_displacement(m, block); /* shared with the deviation */
    for (s = 0; s < size; ++s) {
        u[0] = values[s], u[1] = values[size + s], u[2] = values[2 * size + s];
        place(m, b->point[first + s], u, p);
        w->d[s] = point_distance(m, p);
    }
    return size;
}

void jxf_point_distances(const jxf_model *m, double *out) {
    const jxf_blocks *b = &m->blocks;
    const cell_scratch w = scratch_of(m);
    const double *x = position_coords(m, w.x);
    int block, s, size;
    for (block = 0; block < b->count; ++block) {
        size = block_distances(m, block, x, &w);
        for (s = 0; s < size; ++s) out[b->point[b->start[block] + s]] = w.d[s];
    }
}

/* The smallest distance of block B's members for the coordinates x. */
static double block_min(const jxf_model *m, int block, const double *x, const cell_scratch *w) {
    double best = HUGE_VAL;
    int s;
    const int size = block_distances(m, block, x, w);
    for (s = 0; s < size; ++s) best = w->d[s] < best ? w->d[s] : best;
    return best;
}

/* The largest magnitude of the obstacle records' values (m): the scale of their rounding. */
static double obstacle_scale(const jxf_model *m) {
    double scale = 0.0;
    size_t i;
    for (i = 0; i < (size_t)m->n_obstacles * JXF_OBSTACLE_VALUES; ++i)
        if (i % JXF_OBSTACLE_VALUES != 0 && fabs(m->obstacles[i]) > scale)
            scale = fabs(m->obstacles[i]);
    return scale;
}

/* Relative size of the slack taken off a block's lower bound of the distance, per metre of
 * the coordinates involved: it covers the rounding of the computed distances (tens of
 * operations of relative DBL_EPSILON on coordinates of that size: ~1e-14) with room to
 * spare, so that a block left out cannot hold a computed distance below the smallest one
 * found; a block within a nanometre per metre of it is simply evaluated. */
#define JXF_DISTANCE_SLACK 1e-9

/* A lower bound of the computed distance of every member of block B, from a point p where
 * the centre is or would be without the displacement: each obstacle's distance is convex
 * with the subgradient g at p, so at a member p' = p + R (X' - X + v) (R the orientation,
 * the identity for a part that does not turn; X the rest positions, |v| <= `moving`: the
 * member's displacement, or its difference from the centre's) d(p') >= d(p) -
 * sum_l |(R^T g)_l| e_l - |v|, e the block's extents. `scale`: the size of the other
 * coordinates involved (m), for the slack. */
static double block_lower(const jxf_model *m, int block, const double p[3], double moving,
                          double scale) {
    const double *extent = m->blocks.extent + 3 * (size_t)block;
    double low = HUGE_VAL, size = scale + moving + extent[0] + extent[1] + extent[2];
    int o, c;
    for (c = 0; c < 3; ++c) size += fabs(p[c]);
    for (o = 0; o < m->n_obstacles; ++o) {
        double g[3], tilt[3];
        double d = obstacle_distance(m->obstacles + JXF_OBSTACLE_VALUES * (size_t)o, p, g);
        for (c = 0; c < 3; ++c)
            tilt[c] = m->turning ? m->rot_now[c] * g[0] + m->rot_now[3 + c] * g[1] +
                                       m->rot_now[6 + c] * g[2]
                                 : g[c];
        d -= fabs(tilt[0]) * extent[0] + fabs(tilt[1]) * extent[1] + fabs(tilt[2]) * extent[2];
        low = d < low ? d : low;
    }
    return low - moving - m->half_thickness - JXF_DISTANCE_SLACK * (1.0 + size);
}

/* 1 if block B may hold a distance below `best`: its lower bound with the displacement's
 * first bound `reach` (already in w->lower) and then with its centre's displacement. */
static int in_reach(const jxf_model *m, int block, const double *x, const cell_scratch *w,
                    double scale, double best) {
    double centre[3], p[3], spread;
    if (w->lower[block] >= best) return 0;
    spread = jxf_block_near(m, block, x, w->magnitude, centre);
    place(m, m->blocks.centre[block], centre, p);
    return block_lower(m, block, p, spread, scale) < best;
}

double jxf_min_distance(const jxf_model *m) {
    const jxf_blocks *b = &m->blocks;
    const int rows = m->n_modes + m->n_static, nB = b->count;
    const double still[3] = {0.0, 0.0, 0.0};
    const cell_scratch w = scratch_of(m);
    const double *x = position_coords(m, w.x);
    double scale = obstacle_scale(m), best, p[3], d;
    int j, block, first = 0;
    for (j = 0; j < rows; ++j) {
        w.magnitude[j] = fabs(x[j]);
        scale += b->top[j] * w.magnitude[j];
    }
    jxf_combine(b->reach, w.magnitude, rows, (size_t)nB, w.reach); /* |u_p| <= reach */
    for (block = 0; block < nB; ++block) {
        place(m, b->centre[block], still, p);
        w.lower[block] = block_lower(m, block, p, w.reach[block], scale);
        if (w.lower[block] < w.lower[first]) first = block;
    }
    best = block_min(m, first, x, &w);
    for (block = 0; block < nB; ++block) {
        if (block == first || (JXF_PRUNE && !in_reach(m, block, x, &w, scale, best))) continue;
        d = block_min(m, block, x, &w);
        best = d < best ? d : best;
    }
    return best;
}

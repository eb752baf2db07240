/* jaxflex FMU: the cell's outputs at the communication point (resource format 3).
 *
 * Cup reactions and stresses are linear in the modal state and the base acceleration,
 * y = Q q + V v + A a + y_rest (jaxflex.outputs: y_rest = -S g, the exact outputs of the part
 * at rest under gravity); they are evaluated when read, from m->q, m->v and m->a_now. The cup
 * utilisation and the von Mises stress are those of jaxflex.loads; the distance of a point
 * (at rest under gravity, moved by the path m->pos and the displacement m->u) to the nearest
 * obstacle is that of jaxflex.cell, less half the part's thickness (its skins). SI units.
 *
 * Obstacle records of JXF_OBSTACLE_VALUES values: a kind code, then the kind's values. The
 * kinds are one table, fmu/obstacles.py, which jxf_config.h carries as JXF_OBSTACLE_* macros:
 * box (centre 3, half edges 3, rotation 9 row-major: the box axes are its columns),
 * half_space (unit normal 3, offset: the solid is normal . x <= offset), triangle (corners
 * 3 x 3). A record of another kind is refused when the resource is loaded
 * (jxf_check_obstacles).
 */
#include <math.h>

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

/* signed distance to a box: negative inside (minus the distance to the nearest face) */
static double box_distance(const double *rec, const double p[3]) {
    const double *centre = rec, *half = rec + 3, *rot = rec + 6;
    double local[3], outside = 0.0, depth = -HUGE_VAL;
    int i;
    for (i = 0; i < 3; ++i) { /* local_i = column i of the rotation . (p - centre) */
        local[i] = rot[i] * (p[0] - centre[0]) + rot[3 + i] * (p[1] - centre[1]) +
                   rot[6 + i] * (p[2] - centre[2]);
    }
    for (i = 0; i < 3; ++i) {
        const double d = fabs(local[i]) - half[i];
        if (d > 0.0) outside += d * d;
        depth = d > depth ? d : depth;
    }
    return outside > 0.0 ? sqrt(outside) : depth;
}

/* distance to a triangle (Ericson, Real-Time Collision Detection, 5.1.5) */
static double triangle_distance(const double *rec, const double p[3]) {
    const double *a = rec, *b = rec + 3, *c = rec + 6;
    double ab[3], ac[3], ap[3], bp[3], cp[3], q[3], d1, d2, d3, d4, d5, d6, va, vb, vc, v, w;
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
    for (i = 0; i < 3; ++i) q[i] = p[i] - q[i];
    return norm3(q);
}

/* Where point k of a turning part is (cell coordinates, m): c + s + R (x_k - c + u_k), the
 * pivot c moved by the path s, R the orientation and u_k the whole elastic displacement
 * (the sag in the current pose included): Phi q + D (a_O - g_b) + D_rot b, q the total
 * modal state (jaxflex.turning_collision). */
static void turning_point(const jxf_model *m, int k, double p[3]) {
    const size_t K = (size_t)m->n_points;
    const int M = m->n_modes;
    double local[3];
    int i, c;
    for (c = 0; c < 3; ++c) {
        const double *shape = m->shapes + (size_t)c * K + (size_t)k; /* row i: + 3 K i */
        double u = 0.0;
        for (i = 0; i < M; ++i) u += shape[3 * K * (size_t)i] * m->q[i];
        for (i = 0; i < m->n_static; ++i)
            u += shape[3 * K * (size_t)(M + i)] *
                 (i < 3 ? m->a_now[i] - m->g_now[i] : m->b_now[i - 3]);
        local[c] = m->points[3 * (size_t)k + c] - m->pivot[c] + u;
    }
    for (c = 0; c < 3; ++c)
        p[c] = m->pivot[c] + m->pos[c] + m->rot_now[3 * c] * local[0] +
               m->rot_now[3 * c + 1] * local[1] + m->rot_now[3 * c + 2] * local[2];
}

double jxf_point_distance(const jxf_model *m, int k) {
    const size_t K = (size_t)m->n_points;
    double p[3], best = HUGE_VAL;
    int o, i;
    if (m->turning)
        turning_point(m, k, p);
    else
        for (i = 0; i < 3; ++i)
            p[i] = m->rest_points[3 * (size_t)k + i] + m->pos[i] + m->u[i * K + k];
    for (o = 0; o < m->n_obstacles; ++o) {
        const double *rec = m->obstacles + JXF_OBSTACLE_VALUES * (size_t)o;
        double d;
        switch ((int)rec[0]) { /* the codes are checked when the resource is loaded */
            case JXF_OBSTACLE_BOX:
                d = box_distance(rec + 1, p);
                break;
            case JXF_OBSTACLE_HALF_SPACE:
                d = dot3(rec + 1, p) - rec[4];
                break;
            case JXF_OBSTACLE_TRIANGLE:
                d = triangle_distance(rec + 1, p);
                break;
            default:
                d = HUGE_VAL;
                break;
        }
        best = d < best ? d : best;
    }
    return best - m->half_thickness;
}

/* jaxflex FMU: what the importer reads, one function per variable of fmu/variables.py.
 *
 * Each variable `name` of that table is read by jxf_value_<name>: Float64 / Real variables
 * write one value (or the 3K values of a K x 3 array, row-major), Boolean ones write 0 or 1.
 * The generated jxf_config.h declares the functions of one export and lists them by value
 * reference (JXF_REAL_VALUES, JXF_BOOL_VALUES) for jxf_get_real / jxf_get_bool, so a new
 * output is a row in that table plus its function here. Values are those at the current
 * communication point (jxf_core.c evaluates u, deviation and the settled flag after every
 * step); a function reading the state computes from m->q, m->v (modal, kg^0.5 m and per s)
 * or m->u (displacement, component-major: x of all K points, then y, then z). SI units.
 */
#include <string.h>

#include "jxf_core.h"

void jxf_value_time(const jxf_model *m, double *out) { *out = m->time; }

void jxf_value_ax(const jxf_model *m, double *out) { *out = m->acc[0]; }

void jxf_value_ay(const jxf_model *m, double *out) { *out = m->acc[1]; }

void jxf_value_az(const jxf_model *m, double *out) { *out = m->acc[2]; }

void jxf_value_deviation(const jxf_model *m, double *out) { *out = m->deviation; }

void jxf_value_settle_time(const jxf_model *m, double *out) { *out = m->settle_time; }

void jxf_value_settled(const jxf_model *m, int *out) { *out = m->settled; }

void jxf_value_threshold(const jxf_model *m, double *out) { *out = m->threshold; }

void jxf_value_damping_scale(const jxf_model *m, double *out) { *out = m->damping_scale; }

void jxf_value_use_embedded_trajectory(const jxf_model *m, int *out) {
    *out = m->use_trajectory;
}

/* points + u, (K, 3) row-major, m */
void jxf_value_displaced_points(const jxf_model *m, double *out) {
    const size_t K = (size_t)m->n_points;
    size_t p;
    for (p = 0; p < K; ++p) {
        out[3 * p] = m->points[3 * p] + m->u[p];
        out[3 * p + 1] = m->points[3 * p + 1] + m->u[K + p];
        out[3 * p + 2] = m->points[3 * p + 2] + m->u[2 * K + p];
    }
}

/* (K, 3) row-major, m */
void jxf_value_undeformed_points(const jxf_model *m, double *out) {
    memcpy(out, m->points, 3 * (size_t)m->n_points * sizeof(double));
}

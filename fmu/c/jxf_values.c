/* jaxflex FMU: what the importer reads, one function per variable of fmu/variables.py.
 *
 * Each variable `name` of that table is read by jxf_value_<name>: Float64 / Real variables
 * write one value (or the 3K values of a K x 3 array, row-major), Boolean ones write 0 or 1.
 * The generated jxf_config.h declares the functions of one export and lists them by value
 * reference (JXF_REAL_VALUES, JXF_BOOL_VALUES) for jxf_get_real / jxf_get_bool, so a new
 * output is a row in that table plus its function here. Values are those at the current
 * communication point (jxf_core.c evaluates the deviation and the settled flag after every
 * step); a function reading the state computes from m->q, m->v (modal, kg^0.5 m and per s)
 * or a point's displacement (jxf_point_displacement, jxf_blocks.h: evaluated when read where
 * the step did not need it). SI units.
 */
#include <math.h>
#include <string.h>

#include "jxf_blocks.h"
#include "jxf_cell.h"
#include "jxf_config.h"
#include "jxf_model.h"

void jxf_value_time(const jxf_model *m, double *out) { *out = m->time; }

void jxf_value_ax(const jxf_model *m, double *out) { *out = m->in[JXF_IN_ACC]; }

void jxf_value_ay(const jxf_model *m, double *out) { *out = m->in[JXF_IN_ACC + 1]; }

void jxf_value_az(const jxf_model *m, double *out) { *out = m->in[JXF_IN_ACC + 2]; }

/* the pose inputs of a turning part (jxf_model.h, the drive) */
#define JXF_POSE_VALUE(name, index) \
    void jxf_value_##name(const jxf_model *m, double *out) { *out = m->in[index]; }
JXF_POSE_VALUE(quat_w, JXF_IN_QUAT)
JXF_POSE_VALUE(quat_x, JXF_IN_QUAT + 1)
JXF_POSE_VALUE(quat_y, JXF_IN_QUAT + 2)
JXF_POSE_VALUE(quat_z, JXF_IN_QUAT + 3)
JXF_POSE_VALUE(omega_x, JXF_IN_OMEGA)
JXF_POSE_VALUE(omega_y, JXF_IN_OMEGA + 1)
JXF_POSE_VALUE(omega_z, JXF_IN_OMEGA + 2)
JXF_POSE_VALUE(alpha_x, JXF_IN_ALPHA)
JXF_POSE_VALUE(alpha_y, JXF_IN_ALPHA + 1)
JXF_POSE_VALUE(alpha_z, JXF_IN_ALPHA + 2)

void jxf_value_deviation(const jxf_model *m, double *out) { *out = m->deviation; }

void jxf_value_settle_time(const jxf_model *m, double *out) { *out = m->settle_time; }

void jxf_value_settled(const jxf_model *m, int *out) { *out = m->settled; }

void jxf_value_threshold(const jxf_model *m, double *out) { *out = m->threshold; }

void jxf_value_damping_scale(const jxf_model *m, double *out) { *out = m->damping_scale; }

void jxf_value_use_embedded_trajectory(const jxf_model *m, int *out) {
    *out = m->use_trajectory;
}

/* points + u, (K, 3) row-major, m: block by block (each evaluated now where the step left
 * it out, jxf_blocks.h) */
void jxf_value_displaced_points(const jxf_model *m, double *out) {
    const jxf_blocks *b = &m->blocks;
    int block, s, c;
    for (block = 0; block < b->count; ++block) {
        const double *u = jxf_block_displacement(m, block);
        const int first = b->start[block], size = b->start[block + 1] - first;
        for (s = 0; s < size; ++s) {
            const size_t p = (size_t)b->point[first + s];
            for (c = 0; c < 3; ++c) out[3 * p + c] = m->points[3 * p + c] + u[c * size + s];
        }
    }
}

/* (K, 3) row-major, m */
void jxf_value_undeformed_points(const jxf_model *m, double *out) {
    memcpy(out, m->points, 3 * (size_t)m->n_points * sizeof(double));
}

/* ---- the cell (jxf_cell.c): scalars in FMI 2.0 and 3.0, per item arrays in FMI 3.0 ------ */

void jxf_value_cup_utilisation(const jxf_model *m, double *out) {
    int c;
    *out = 0.0;
    for (c = 0; c < m->n_cups; ++c) {
        const double u = jxf_cup_utilisation(m, c);
        *out = u > *out ? u : *out;
    }
}

void jxf_value_cup_utilisations(const jxf_model *m, double *out) {
    int c;
    for (c = 0; c < m->n_cups; ++c) out[c] = jxf_cup_utilisation(m, c);
}

/* (C, 6) row-major: force N, moment about the cup centre N m */
void jxf_value_cup_reactions(const jxf_model *m, double *out) {
    int c;
    for (c = 0; c < m->n_cups; ++c) jxf_cup_reaction(m, c, out + 6 * c);
}

void jxf_value_max_stress(const jxf_model *m, double *out) {
    int s;
    *out = 0.0;
    for (s = 0; s < m->n_stress; ++s) {
        const double v = jxf_von_mises(m, s);
        *out = v > *out ? v : *out;
    }
}

void jxf_value_point_stresses(const jxf_model *m, double *out) {
    int s;
    for (s = 0; s < m->n_stress; ++s) out[s] = jxf_von_mises(m, s);
}

void jxf_value_min_distance(const jxf_model *m, double *out) { *out = jxf_min_distance(m); }

void jxf_value_point_distances(const jxf_model *m, double *out) { jxf_point_distances(m, out); }

/* jaxflex FMU: the modal forces of the inputs (the drive, jxf_model.h), straight or turning.
 *
 * A part that does not turn: f_m = -gamma_m . a, a the gripper's acceleration (m/s^2).
 *
 * A turning part (jaxflex._turning, in the body frame of the gripper = the model frame, origin
 * O): the pivot c (model frame) moves with the world acceleration a; the orientation R (body
 * -> world) is the unit quaternion (w, x, y, z) of the inputs (normalised here), the angular
 * velocity w and acceleration alpha are body components. Then
 *     a_O = R^T a + alpha x (-c) + w x (w x (-c)),   g_b = R^T g,
 *     f_m = -gamma_m . (a_O - g_b) - gamma_rot,m . alpha - tr(A(w) S_m),
 * with A(w) = w w^T - |w|^2 I, S_m[i][j] = phi_m^T M (e_j r_i) the inertia shape integrals
 * and gamma_rot,m[k] = eps_kij S_m[i][j]. The coefficients b[3 i + j] = B_ji of the
 * rotational loads (B = [alpha]_x + A(w)) drive the static response to them, the last nine
 * residual coordinates where the resource has R = 12 (jaxflex._rotation_residual). SI units.
 */
#include <math.h>

#include "jxf_model.h"
#include "jxf_turning.h"

/* R (row-major, body -> world) of the quaternion q = (w, x, y, z), normalised; -1 if q has no
 * direction. */
static int rotation_of(const double q[4], double r[9]) {
    const double n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    double w, x, y, z, s;
    if (!(n2 > 0.0 && isfinite(n2))) return -1;
    s = 1.0 / sqrt(n2);
    w = q[0] * s, x = q[1] * s, y = q[2] * s, z = q[3] * s;
    r[0] = 1.0 - 2.0 * (y * y + z * z);
    r[1] = 2.0 * (x * y - w * z);
    r[2] = 2.0 * (x * z + w * y);
    r[3] = 2.0 * (x * y + w * z);
    r[4] = 1.0 - 2.0 * (x * x + z * z);
    r[5] = 2.0 * (y * z - w * x);
    r[6] = 2.0 * (x * z - w * y);
    r[7] = 2.0 * (y * z + w * x);
    r[8] = 1.0 - 2.0 * (x * x + y * y);
    return 0;
}

static void cross(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

int jxf_drive_forces(const jxf_model *m, const double in[JXF_IN_COUNT], double *f,
                     double a_body[3], double g_body[3], double b[9], double rotation[9]) {
    const double *a = in + JXF_IN_ACC, *w = in + JXF_IN_OMEGA, *alpha = in + JXF_IN_ALPHA;
    double *r = rotation, arm[3], euler[3], spin[3], whirl[3], load[3], spin_tensor[9], w2;
    int i, j;
    if (!m->turning) {
        for (i = 0; i < m->n_modes; ++i) {
            const double *g = m->gamma + 3 * i;
            f[i] = -(a[0] * g[0] + a[1] * g[1] + a[2] * g[2]);
        }
        for (j = 0; j < 3; ++j) a_body[j] = a[j], g_body[j] = 0.0;
        for (j = 0; j < 9; ++j) b[j] = 0.0, r[j] = j % 4 == 0 ? 1.0 : 0.0;
        return 0;
    }
    if (rotation_of(in + JXF_IN_QUAT, r) != 0) {
        jxf_log(m, JXF_LOG_ERROR, "the orientation quaternion (quat_w, quat_x, quat_y, quat_z) "
                "= (%g, %g, %g, %g) has no direction: give a unit quaternion (body to world)",
                in[JXF_IN_QUAT], in[JXF_IN_QUAT + 1], in[JXF_IN_QUAT + 2], in[JXF_IN_QUAT + 3]);
        return -1;
    }
    for (j = 0; j < 3; ++j) arm[j] = -m->pivot[j]; /* from the pivot to the origin */
    cross(alpha, arm, euler);
    cross(w, arm, spin);
    cross(w, spin, whirl);
    for (j = 0; j < 3; ++j) { /* column j of R . (a, g): body components */
        a_body[j] = r[j] * a[0] + r[3 + j] * a[1] + r[6 + j] * a[2] + euler[j] + whirl[j];
        g_body[j] = r[j] * m->world_gravity[0] + r[3 + j] * m->world_gravity[1] +
                    r[6 + j] * m->world_gravity[2];
        load[j] = a_body[j] - g_body[j];
    }
    w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) spin_tensor[3 * i + j] = w[i] * w[j] - (i == j ? w2 : 0.0);
    /* b[3 i + j] = B_ji = eps_kij alpha_k + w_i w_j - |w|^2 delta_ij */
    for (j = 0; j < 9; ++j) b[j] = spin_tensor[j];
    b[1] += alpha[2], b[3] -= alpha[2]; /* (i, j) = (x, y), (y, x) */
    b[5] += alpha[0], b[7] -= alpha[0]; /* (y, z), (z, y) */
    b[6] += alpha[1], b[2] -= alpha[1]; /* (z, x), (x, z) */
    for (i = 0; i < m->n_modes; ++i) {
        const double *g = m->gamma + 3 * i, *s = m->shape_integrals + 9 * (size_t)i;
        const double rot[3] = {s[5] - s[7], s[6] - s[2], s[1] - s[3]}; /* eps_kij S_ij */
        double centrifugal = 0.0;
        for (j = 0; j < 9; ++j) centrifugal += spin_tensor[j] * s[j]; /* A symmetric */
        f[i] = -(load[0] * g[0] + load[1] * g[1] + load[2] * g[2]) -
               (alpha[0] * rot[0] + alpha[1] * rot[1] + alpha[2] * rot[2]) - centrifugal;
    }
    return 0;
}

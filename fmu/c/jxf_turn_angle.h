/* The turn between two samples of a turning move, shared by the part (jxf_core.c, its
 * embedded move) and the trajectory source (jxf_source.c): from sample k, with the body
 * angular velocity w_k and the angular acceleration linear from alpha_k to alpha_k+1 over
 * the step dt, the body rotation vector `s` s later is
 *     phi = w_k s + alpha_k s^2 / 2 + (alpha_k+1 - alpha_k) s^3 / (6 dt),
 * and the angular velocity w_k + alpha_k s + (alpha_k+1 - alpha_k) s^2 / (2 dt); the
 * orientation is R_k exp([phi]_x), exact for a turn about a fixed axis (jaxflex._pose). */
#ifndef JXF_TURN_ANGLE_H
#define JXF_TURN_ANGLE_H

/* phi (rad) and, if `omega` is not NULL, the angular velocity (rad/s), body components. */
static inline void jxf_turn_angle(const double w[3], const double alpha[3],
                                  const double alpha_next[3], double dt, double s,
                                  double phi[3], double omega[3]) {
    int i;
    for (i = 0; i < 3; ++i) {
        const double jerk = (alpha_next[i] - alpha[i]) / dt;
        phi[i] = w[i] * s + alpha[i] * s * s / 2.0 + jerk * s * s * s / 6.0;
        if (omega != NULL) omega[i] = w[i] + alpha[i] * s + jerk * s * s / 2.0;
    }
}

#endif

/* jaxflex part FMU: the state of the exact discrete-time modal recursion of a flexible part.
 *
 * Per mode i (state q_i, v_i = dq_i/dt) the part obeys
 *     q'' + 2 zeta_i omega_i q' + omega_i^2 q = -gamma_i . a(t)
 * and the point displacements are u_p = sum_i phi_i(p) q_i. Over a step of length h with an
 * acceleration that is linear in time (first-order hold) the state advances exactly as
 *     x(h) = Phi x(0) + G0 f(0) + G1 f(h),    G0 = J1 / h,  G1 = J0 - G0
 * (the same discretisation as jaxflex._discretize: closed form for omega h >= 0.1, a 16-term
 * series of the matrix exponential; jxf_core.c). A held input is the special case
 * f(h) = f(0).
 *
 * A turning part (JXF_TURNING, jxf_turning.c) takes its pose as inputs as well and is forced
 * in its body frame as in jaxflex._turning: f = -gamma . (a_O - g_b) - gamma_rot . alpha
 * - tr(A(w) S), with the same first-order hold of f over a step.
 *
 * This header holds the part's state, struct jxf_model, and only that: the part FMU's
 * implementation of the core interface jxf_model_* of jxf_fmu.h (jxf_core.c, under the FMI
 * bindings jxf_fmi2.c and jxf_fmi3.c) calls down into the modules that read it: jxf_values.c
 * (one reading function per variable), jxf_cell.c (the cell's outputs, jxf_cell.h) and
 * jxf_turning.c (the forcing of the inputs, jxf_turning.h); none of them calls the core.
 * SI units: m, s, m/s^2, Hz; modal coordinates in kg^0.5 m.
 */
#ifndef JXF_MODEL_H
#define JXF_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "jxf_log.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifndef JXF_MODEL_TYPEDEF /* also in jxf_fmu.h */
#define JXF_MODEL_TYPEDEF
typedef struct jxf_model jxf_model;
#endif

/* Coefficients of the exact step for one step length, all modes. */
typedef struct {
    double h;            /* step length in s (0: slot unused) */
    double damping;      /* damping scale the slot was computed with */
    unsigned long stamp; /* last use, for least-recently-used replacement */
    double *p11, *p12, *p21, *p22; /* Phi */
    double *g0q, *g0v, *g1q, *g1v; /* G0, G1 */
} jxf_coeffs;

#define JXF_CACHE_SLOTS 4

/* The inputs that drive the part at one instant (a "drive"), in the order of the input
 * variables of fmu/variables.py (JXF_INPUT_VRS): the acceleration of the gripper (m/s^2; of
 * the pivot in world components for a turning part), then, for a turning part only, the
 * orientation quaternion body -> world (w, x, y, z), the angular velocity (rad/s) and the
 * angular acceleration (rad/s^2), both in body components. */
enum { JXF_IN_ACC = 0, JXF_IN_QUAT = 3, JXF_IN_OMEGA = 7, JXF_IN_ALPHA = 10, JXF_IN_COUNT = 13 };
/* Values per sample of a turning part's embedded poses: quaternion, omega, alpha (as the
 * drive's from JXF_IN_QUAT). */
#define JXF_POSE_VALUES 10

/* The points in spatially compact blocks (jxf_blocks.c): block B holds the points of slots
 * start[B] .. start[B + 1] - 1 (JXF_BLOCK_POINTS of them, the last block at most: `largest`
 * is the largest), `point` maps a slot to its point and
 * `slot` a point to its slot; `centre` is a member of each block. What bounds a block's
 * members for the coordinates x of the shape rows psi_j (j < M + R: the modes, then the
 * residual rows), per block and row (jxf_blocks.c explains the bounds):
 *   reach   (M + R, nB)      max_p |psi_j(p)| (grouped for jxf_combine, jxf_blocks.h)
 *   near    (nB, M + R, 4)   the centre's shape psi_j(c) (3), the radius max_p |psi_j(p) -
 *                            psi_j(c)|
 *   slope   (nB, M + R, 12)  the gradient L_j (9: [3 l + k] = d psi_jk / d X_l), the largest
 *                            residual of psi_j(p) - psi_j(c) - L_j (X_p - X_c), the lever
 *                            sum_l |L_j[., l]| span_l, a zero
 *   span    (nB, 3)          max_p |X_p - X_c| per axis of the points (model frame), m
 *   extent  (nB, 3)          the same of the positions at rest (with obstacles, else NULL)
 *   top     (M + R)          max_B reach: max_p |psi_j(p)| over every point
 * `stamp` tells for which state the block's part of m->u was evaluated, `seed` is the
 * block where the deviation was largest at the last evaluation, `unbounded` the number of
 * coming evaluations that do not try the bounds (jxf_blocks_deviation); `offered` and
 * `evaluated` count the blocks the deviation's evaluations had and evaluated (logged when
 * the model is freed). */
typedef struct {
    int count, largest, seed, unbounded;
    double offered, evaluated;
    int *start, *point, *slot, *centre;
    double *reach, *near, *slope, *span, *extent, *top;
    uint64_t *stamp;
    double *work;      /* scratch of jxf_blocks.c: nB + 3 largest + M + R values */
    double *cell_work; /* scratch of the distances (jxf_cell.c), NULL without obstacles */
} jxf_blocks;

struct jxf_model {
    /* model data from the resource file (views into `buffer`) */
    int n_points, n_modes, n_traj;
    int n_static;           /* R: 3 where the shapes end with the static residual, else 0 */
    double traj_dt;
    const double *freq_hz;  /* (M) */
    const double *zeta;     /* (M) */
    const double *gamma;    /* (M, 3) */
    const double *shapes;   /* (M + R, 3, K) in the resource: x rows of all points, then y,
                             * then z; block by block once loaded (jxf_blocks.c): block B's
                             * (M + R, 3 n_B) from 3 (M + R) start[B], grouped for
                             * jxf_combine (jxf_blocks.h) */
    const double *points;   /* (K, 3) */
    const double *traj;     /* (N, 3) acceleration samples, m/s^2 */
    unsigned char *buffer;

    /* the cell (resource format 3, all optional; jxf_cell.c): C cups, S stress points,
     * O obstacle records. Outputs y = Q q + V v + A a + y_rest per cup (6 rows: force on the
     * part N, moment about the cup centre N m) and per stress point (6 Voigt rows, Pa), with
     * y_rest the exact outputs at rest under gravity. */
    int n_cups, n_stress, n_obstacles;
    const double *gravity;                    /* (3) m/s^2 */
    double cup_safety;                        /* safety factor of the cup utilisation */
    double half_thickness;                    /* m: the skins' distance from the mid-surface */
    const double *cup_normal;                 /* (C, 3) from the part into the cup */
    const double *cup_radius, *cup_holding, *cup_friction; /* (C) m, N, - */
    const double *cup_q, *cup_v, *cup_a;      /* (6C, M), (6C, M), (6C, 3) */
    const double *cup_rest;                   /* (6C) at rest under gravity */
    const double *stress_q, *stress_v, *stress_a; /* (6S, M), (6S, M), (6S, 3) */
    const double *stress_rest;                /* (6S) at rest under gravity */
    const double *rest_points;                /* (K, 3) points at rest under gravity, m */
    const double *obstacles;                  /* (O, 16) records, see jxf_cell.c */

    /* a turning part (resource field T = 1; jxf_turning.c) */
    int turning;
    const double *shape_integrals; /* (M, 3, 3) S_m[i][j] = phi_m^T M (e_j r_i), kg^0.5 m */
    const double *pivot;           /* (3) m, model frame: the point the acceleration is of */
    const double *world_gravity;   /* (3) m/s^2, world components */
    const double *traj_pose;       /* (N, JXF_POSE_VALUES) the embedded move's poses */
    const double *cup_rot;         /* (6C, 9) the cups' maps A_rot of the rotational loads b */
    const double *stress_rot;      /* (6S, 9) the stresses' maps A_rot */

    /* parameters */
    double threshold;     /* m */
    double damping_scale; /* multiplies every zeta */
    int use_trajectory;   /* replay the embedded trajectory instead of the inputs */
    int started;          /* initialization left (fixed parameters can no longer change) */

    /* inputs (the drive, JXF_IN_*): value at the communication point and time derivative */
    double in[JXF_IN_COUNT];
    double in_rate[JXF_IN_COUNT];
    double *f0, *f1;     /* (M) modal forces at the ends of a step, kg^0.5 m/s^2 */
    double *f_next;      /* (M) scratch: the forces of the next embedded sample */

    /* state and outputs */
    double start_time, time;
    double *q, *v;       /* (M) */
    double *saved;       /* (2M): q and v before a step, restored if it fails */
    double *u;           /* (3K) displacement, block by block: block B's (3, n_B) from
                          * 3 start[B] (x of its members in slot order, then y, then z),
                          * evaluated when needed for the state its stamp names
                          * (jxf_blocks.c; read it with jxf_point_displacement) */
    double *coords;      /* (M + R) the shapes' coordinates: q (less the sag), then a_now */
    double deviation;    /* max_p |u_p|, m */
    double a_now[3];     /* base acceleration at the communication point, m/s^2 (a turning
                          * part: of the model frame's origin, body components) */
    double g_now[3];     /* a turning part: gravity in body components there, m/s^2 */
    double b_now[9];     /* a turning part: the rotational load coefficients there, 1/s^2 */
    double rot_now[9];   /* a turning part: the orientation there (body -> world, row-major) */
    double pos[3], vel[3]; /* the path travelled since the start, m and m/s (exact) */
    int settled;         /* deviation <= threshold at the current communication point */
    double settle_time;  /* time the settled flag last went true, s */
    uint64_t state;      /* stamp of the current state: changes whenever the state does */
    jxf_blocks blocks;

    jxf_coeffs cache[JXF_CACHE_SLOTS];
    unsigned long clock;
    unsigned long recomputations;

    const jxf_logger *log; /* the instance's (jxf_fmu.h, jxf_log.h) */
};

/* Format a message (printf-style) and send it to the model's logger (jxf_log.h). */
#define jxf_log(m, ...) jxf_logf((m)->log, __VA_ARGS__)

#ifdef __cplusplus
}
#endif

#endif /* JXF_MODEL_H */

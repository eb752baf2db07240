/* jaxflex FMU core: the exact discrete-time modal recursion of a flexible part.
 *
 * Per mode i (state q_i, v_i = dq_i/dt) the part obeys
 *     q'' + 2 zeta_i omega_i q' + omega_i^2 q = -gamma_i . a(t)
 * and the point displacements are u_p = sum_i phi_i(p) q_i. Over a step of length h with an
 * acceleration that is linear in time (first-order hold) the state advances exactly as
 *     x(h) = Phi x(0) + G0 f(0) + G1 f(h),    G0 = J1 / h,  G1 = J0 - G0
 * (the same discretisation as jaxflex.discretize: closed form for omega h >= 0.1, a 16-term
 * series of the matrix exponential below). A held input is the special case f(h) = f(0).
 *
 * The FMI 2.0 and FMI 3.0 glue files (jxf_fmi2.c, jxf_fmi3.c) call only this interface;
 * jxf_values.c holds one reading function per variable.
 * SI units: m, s, m/s^2, Hz; modal coordinates in kg^0.5 m.
 */
#ifndef JXF_CORE_H
#define JXF_CORE_H

#include <stddef.h>

#include "jxf_config.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { JXF_LOG_INFO = 0, JXF_LOG_WARNING = 1, JXF_LOG_ERROR = 2 };

/* Receives every message of the core; level is one of JXF_LOG_*. */
typedef void (*jxf_log_fn)(void *context, int level, const char *message);

/* Coefficients of the exact step for one step length, all modes. */
typedef struct {
    double h;            /* step length in s (0: slot unused) */
    double damping;      /* damping scale the slot was computed with */
    unsigned long stamp; /* last use, for least-recently-used replacement */
    double *p11, *p12, *p21, *p22; /* Phi */
    double *g0q, *g0v, *g1q, *g1v; /* G0, G1 */
} jxf_coeffs;

#define JXF_CACHE_SLOTS 4

typedef struct jxf_model {
    /* model data from the resource file (views into `buffer`) */
    int n_points, n_modes, n_traj;
    int n_static;           /* R: 3 where the shapes end with the static residual, else 0 */
    double traj_dt;
    const double *freq_hz;  /* (M) */
    const double *zeta;     /* (M) */
    const double *gamma;    /* (M, 3) */
    const double *shapes;   /* (M + R, 3, K): x rows of all points, then y, then z */
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

    /* parameters */
    double threshold;     /* m */
    double damping_scale; /* multiplies every zeta */
    int use_trajectory;   /* replay the embedded trajectory instead of the inputs */

    int state;            /* one of the JXF_* life-cycle states */
    double setup_time;    /* start time given for the coming initialization, s */

    /* inputs: value at the communication point and its time derivative */
    double acc[3];
    double acc_rate[3];

    /* state and outputs */
    double start_time, time;
    double *q, *v;       /* (M) */
    double *saved;       /* (2M): q and v before a step, restored if it fails */
    double *u;           /* (3K) displacement, component-major like `shapes` */
    double *coords;      /* (M + R) the shapes' coordinates: q, then a_now */
    double deviation;    /* max_p |u_p|, m */
    double a_now[3];     /* base acceleration at the communication point, m/s^2 */
    double pos[3], vel[3]; /* the path travelled since the start, m and m/s (exact) */
    int settled;         /* deviation <= threshold at the current communication point */
    double settle_time;  /* time the settled flag last went true, s */

    jxf_coeffs cache[JXF_CACHE_SLOTS];
    unsigned long clock;
    unsigned long recomputations;

    jxf_log_fn log;
    void *log_context;
    int debug;
} jxf_model;

/* Life cycle shared by FMI 2.0 and 3.0 (bit flags, so a set of states is an OR). */
enum { JXF_INSTANTIATED = 1, JXF_INITIALIZATION = 2, JXF_STEP = 4, JXF_TERMINATED = 8 };
#define JXF_ANY_STATE 15
#define JXF_LIVE (JXF_INSTANTIATED | JXF_INITIALIZATION | JXF_STEP)

/* Load the resource file found in `resource_location` (a file: URI or a directory path),
 * check it against this build (sizes, token) and return a model at rest with the start
 * values of the parameters. Returns NULL after logging the reason on any failure. */
jxf_model *jxf_create(const char *resource_location, const char *token, jxf_log_fn log,
                      void *log_context, int debug);

/* Free everything owned by the model (NULL is allowed). */
void jxf_destroy(jxf_model *m);

/* Life-cycle calls of the importer; `function` names the FMI function in messages. Each
 * returns 0, or -1 after logging (also for m == NULL or a call in the wrong state).
 * jxf_allowed returns 1 if the model is in one of `states`, else logs and returns 0. */
int jxf_allowed(jxf_model *m, const char *function, int states);
int jxf_unsupported(jxf_model *m, const char *function);
int jxf_set_logging(jxf_model *m, const char *function, int on, size_t n_categories,
                    const char *const categories[]);
int jxf_setup(jxf_model *m, const char *function, double start_time);
int jxf_enter_initialization(jxf_model *m, const char *function);
int jxf_exit_initialization(jxf_model *m, const char *function);
int jxf_terminate(jxf_model *m, const char *function);
/* Back to the state after jxf_create: parameters at start values, inputs 0, at rest. */
int jxf_reset(jxf_model *m, const char *function);

/* Variables by value reference (see jxf_config.h). Getters read through the functions of
 * jxf_values.c; jxf_get_real writes jxf_real_size(vr) values (3K for the K x 3 arrays of
 * FMI 3.0, else 1). Setters check the value and store it only when `apply` is nonzero, so a
 * caller can check a whole batch before changing anything. All return 0 on success and -1
 * after logging the reason. */
size_t jxf_real_size(unsigned vr);
int jxf_get_real(const jxf_model *m, unsigned vr, double *value);
int jxf_set_real(jxf_model *m, unsigned vr, double value, int apply);
int jxf_set_input_rate(jxf_model *m, unsigned vr, int order, double value, int apply);
int jxf_get_bool(const jxf_model *m, unsigned vr, int *value);
int jxf_set_bool(jxf_model *m, unsigned vr, int value, int apply);

/* Advance from `t` (the current communication point) by `h` s (step mode only); 0 on
 * success, -1 on error (logged, state untouched): a step that is not finite and > 0, that
 * does not advance the time in double precision, or whose exact solution is not finite. The
 * work is bounded: one exact step per embedded trajectory sample crossed (integer sample
 * indices, never accumulated time), at most N + 1. */
int jxf_do_step(jxf_model *m, double t, double h);

/* The cell's outputs at the communication point (jxf_cell.c): utilisation of cup c, von
 * Mises stress at stress point s (Pa), distance of point k to the nearest obstacle (m). */
double jxf_cup_utilisation(const jxf_model *m, int c);
double jxf_von_mises(const jxf_model *m, int s);
double jxf_point_distance(const jxf_model *m, int k);

/* Format a message and send it to the model's logger (printf-style). */
void jxf_log(const jxf_model *m, int level, const char *format, ...);

#ifdef __cplusplus
}
#endif

#endif /* JXF_CORE_H */

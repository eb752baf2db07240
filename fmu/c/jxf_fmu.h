/* The two layers under the FMI bindings of every jaxflex FMU (the part and the trajectory
 * source):
 *
 * 1. The core interface jxf_model_*: what one FMU computes (create, reset, start, set inputs
 *    and parameters, step, get outputs, free), with no FMI in it. Each FMU's core implements
 *    it once: the part in jxf_core.c (+ jxf_values.c, jxf_cell.c, jxf_turning.c), the
 *    trajectory source in jxf_source.c. An FMU links exactly one core.
 * 2. The instance jxf_instance (jxf_fmu.c): what every FMU does the same way in FMI 2.0 and
 *    3.0: the life cycle (which call is allowed in which state), the checks of a step,
 *    variable access in batches (every value checked before any is stored); logging is
 *    jxf_log.c's.
 *
 * The FMI bindings jxf_fmi2.c and jxf_fmi3.c, each written once, translate the standard's
 * functions into calls of the instance. SI units: s, m, m/s^2.
 */
#ifndef JXF_FMU_H
#define JXF_FMU_H

#include <stddef.h>

#include "jxf_log.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- the core interface (one implementation per FMU) --------------------------------- */

#ifndef JXF_MODEL_TYPEDEF /* also in the part's jxf_model.h */
#define JXF_MODEL_TYPEDEF
typedef struct jxf_model jxf_model;
#endif

/* A model at rest at time 0 with the start values of its parameters, for the importer's
 * `token`, with its data from `resource_location` (a file: URI or a directory path) where it
 * has any. Returns NULL after logging the reason. `log` outlives the model. */
jxf_model *jxf_model_create(const char *resource_location, const char *token,
                            const jxf_logger *log);
/* Free everything the model owns (NULL is allowed). */
void jxf_model_free(jxf_model *m);
/* Back to the state after jxf_model_create: parameters at start values, inputs 0, at rest. */
void jxf_model_reset(jxf_model *m);
/* Leaving initialization: at rest at `start_time` s with the parameters set so far. */
void jxf_model_start(jxf_model *m, double start_time);
/* The current communication point, s. */
double jxf_model_time(const jxf_model *m);

/* Variables by value reference. A getter writes jxf_model_real_size(vr) values (1 for a
 * scalar); jxf_model_get_output_rate the time derivative of order `order` of an output. A
 * setter checks the value and stores it only when `apply` is nonzero, so that a batch is
 * checked before anything changes. All return 0, or -1 after logging the reason. */
size_t jxf_model_real_size(unsigned vr);
int jxf_model_get_real(const jxf_model *m, unsigned vr, double *value);
int jxf_model_get_output_rate(const jxf_model *m, unsigned vr, int order, double *value);
int jxf_model_get_bool(const jxf_model *m, unsigned vr, int *value);
int jxf_model_set_real(jxf_model *m, unsigned vr, double value, int apply);
int jxf_model_set_input_rate(jxf_model *m, unsigned vr, int order, double value, int apply);
int jxf_model_set_bool(jxf_model *m, unsigned vr, int value, int apply);

/* Advance from `t` (the current communication point) by `h` s; t, h > 0 and t + h > t are
 * finite (checked by jxf_do_step). 0, or -1 after logging, with the state unchanged. */
int jxf_model_do_step(jxf_model *m, double t, double h);

/* ---- the instance (jxf_fmu.c): life cycle shared by FMI 2.0 and 3.0 ------------------ */

/* States (bit flags, so a set of states is an OR). */
enum { JXF_INSTANTIATED = 1, JXF_INITIALIZATION = 2, JXF_STEP = 4, JXF_TERMINATED = 8 };
#define JXF_ANY_STATE 15
#define JXF_LIVE (JXF_INSTANTIATED | JXF_INITIALIZATION | JXF_STEP)

typedef struct {
    jxf_model *model;
    jxf_logger log;
    int state;
    double setup_time; /* start time given for the coming initialization, s */
} jxf_instance;

/* With inst->log set: create the model; 0, or -1 after logging. */
int jxf_instance_create(jxf_instance *inst, const char *resource_location, const char *token);
void jxf_instance_free(jxf_instance *inst);

/* `function` names the FMI function in messages. Each returns 0, or -1 after logging (also
 * for inst == NULL or a call in the wrong state); jxf_allowed returns 1 if `inst` is in one
 * of `states`, else logs and returns 0. */
int jxf_allowed(jxf_instance *inst, const char *function, int states);
int jxf_unsupported(jxf_instance *inst, const char *function);
int jxf_set_logging(jxf_instance *inst, const char *function, int on, size_t n_categories,
                    const char *const categories[]);
int jxf_setup(jxf_instance *inst, const char *function, double start_time);
int jxf_enter_initialization(jxf_instance *inst, const char *function);
int jxf_exit_initialization(jxf_instance *inst, const char *function);
int jxf_terminate(jxf_instance *inst, const char *function);
int jxf_reset(jxf_instance *inst, const char *function);
int jxf_do_step(jxf_instance *inst, const char *function, double t, double h);

/* Variables of a type the FMU does not have: fine for an empty request (n == 0). */
int jxf_no_variables(jxf_instance *inst, const char *function, size_t n);
/* `n_values` values for the `n_vr` variables (arrays hold several). */
int jxf_get_reals(jxf_instance *inst, const char *function, const unsigned vr[], size_t n_vr,
                  double values[], size_t n_values);
int jxf_set_reals(jxf_instance *inst, const char *function, const unsigned vr[], size_t n_vr,
                  const double values[], size_t n_values);
/* Time derivatives of the given orders (scalars only). */
int jxf_get_output_rates(jxf_instance *inst, const char *function, const unsigned vr[],
                         size_t n_vr, const int orders[], double values[], size_t n_values);
int jxf_set_input_rates(jxf_instance *inst, const char *function, const unsigned vr[],
                        size_t n_vr, const int orders[], const double values[]);
/* Booleans (whose C type differs between FMI 2.0 and 3.0) are read and written by the
 * bindings with jxf_model_get_bool / jxf_model_set_bool after jxf_allowed. */

/* Around the bindings' generated definitions: unused parameters are part of the standard's
 * signatures. */
#if defined(__GNUC__)
#define JXF_SIGNATURES_BEGIN \
    _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wunused-parameter\"")
#define JXF_SIGNATURES_END _Pragma("GCC diagnostic pop")
#else
#define JXF_SIGNATURES_BEGIN
#define JXF_SIGNATURES_END
#endif

/* The FMU-state functions, unsupported in both versions (canGetAndSetFMUstate and
 * canSerializeFMUstate are false): the same six functions, written once for the bindings'
 * UNSUPPORTED(name, why, parameters...). P is the prefix (fmi2, fmi3), S the case of the "s"
 * of "FMUstate" in the version's names (s, S), DESERIALIZE the deserializing function. */
#define JXF_PASTE4(a, b, c, d) a##b##c##d
#define JXF_STATE(P, S) JXF_PASTE4(P, FMU, S, tate)
#define JXF_NO_FMU_STATE(P, S, DESERIALIZE)                                                 \
    UNSUPPORTED(JXF_PASTE4(P, GetFMU, S, tate), "canGetAndSetFMU" #S "tate is false",       \
                JXF_STATE(P, S) * state)                                                    \
    UNSUPPORTED(JXF_PASTE4(P, SetFMU, S, tate), "canGetAndSetFMU" #S "tate is false",       \
                JXF_STATE(P, S) state)                                                      \
    UNSUPPORTED(JXF_PASTE4(P, FreeFMU, S, tate), "canGetAndSetFMU" #S "tate is false",      \
                JXF_STATE(P, S) * state)                                                    \
    UNSUPPORTED(JXF_PASTE4(P, SerializedFMU, S, tateSize), "canSerializeFMU" #S "tate is "  \
                "false", JXF_STATE(P, S) state, size_t *size)                               \
    UNSUPPORTED(JXF_PASTE4(P, SerializeFMU, S, tate), "canSerializeFMU" #S "tate is false", \
                JXF_STATE(P, S) state, P##Byte serialized[], size_t size)                   \
    UNSUPPORTED(DESERIALIZE, "canSerializeFMU" #S "tate is false",                          \
                const P##Byte serialized[], size_t size, JXF_STATE(P, S) * state)

#ifdef __cplusplus
}
#endif

#endif /* JXF_FMU_H */

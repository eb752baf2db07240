/* The instance of a jaxflex FMU: life cycle, step checks and batched variable access, the
 * same for FMI 2.0 and 3.0 and for every FMU's core. See jxf_fmu.h. */
#include "jxf_fmu.h"

#include <math.h>
#include <string.h>

/* ---- life cycle --------------------------------------------------------------------- */

int jxf_instance_create(jxf_instance *inst, const char *resource_location, const char *token) {
    inst->state = JXF_INSTANTIATED;
    inst->setup_time = 0.0;
    inst->model = jxf_model_create(resource_location, token, &inst->log);
    return inst->model == NULL ? -1 : 0;
}

void jxf_instance_free(jxf_instance *inst) {
    jxf_model_free(inst->model);
    inst->model = NULL;
}

int jxf_allowed(jxf_instance *inst, const char *function, int states) {
    if (inst == NULL || inst->model == NULL) return 0;
    if (inst->state & states) return 1;
    jxf_logf(&inst->log, JXF_LOG_ERROR, "%s is not allowed in the current state", function);
    return 0;
}

int jxf_unsupported(jxf_instance *inst, const char *function) {
    if (inst != NULL)
        jxf_logf(&inst->log, JXF_LOG_ERROR, "%s is not supported by this co-simulation FMU",
                 function);
    return -1;
}

int jxf_set_logging(jxf_instance *inst, const char *function, int on, size_t n_categories,
                    const char *const categories[]) {
    static const char *known[] = {"logStatusError", "logStatusWarning", "logAll"};
    size_t i;
    int k, found;
    if (!jxf_allowed(inst, function, JXF_ANY_STATE)) return -1;
    for (i = 0; i < n_categories; ++i) {
        const char *name = categories ? categories[i] : NULL;
        for (found = 0, k = 0; k < 3; ++k) found |= name != NULL && !strcmp(name, known[k]);
        if (!found) {
            jxf_logf(&inst->log, JXF_LOG_ERROR, "%s: unknown log category '%s' (known: "
                     "logStatusError, logStatusWarning, logAll)", function,
                     name ? name : "(null)");
            return -1;
        }
    }
    inst->log.debug = on != 0;
    return 0;
}

int jxf_setup(jxf_instance *inst, const char *function, double start_time) {
    if (!jxf_allowed(inst, function, JXF_INSTANTIATED)) return -1;
    if (!isfinite(start_time)) {
        jxf_logf(&inst->log, JXF_LOG_ERROR, "%s: startTime %g is not finite", function,
                 start_time);
        return -1;
    }
    inst->setup_time = start_time;
    return 0;
}

int jxf_enter_initialization(jxf_instance *inst, const char *function) {
    if (!jxf_allowed(inst, function, JXF_INSTANTIATED)) return -1;
    inst->state = JXF_INITIALIZATION;
    return 0;
}

int jxf_exit_initialization(jxf_instance *inst, const char *function) {
    if (!jxf_allowed(inst, function, JXF_INITIALIZATION)) return -1;
    jxf_model_start(inst->model, inst->setup_time);
    inst->state = JXF_STEP;
    return 0;
}

int jxf_terminate(jxf_instance *inst, const char *function) {
    if (!jxf_allowed(inst, function, JXF_STEP)) return -1;
    inst->state = JXF_TERMINATED;
    return 0;
}

int jxf_reset(jxf_instance *inst, const char *function) {
    if (!jxf_allowed(inst, function, JXF_ANY_STATE)) return -1;
    jxf_model_reset(inst->model);
    inst->state = JXF_INSTANTIATED;
    inst->setup_time = 0.0;
    return 0;
}

int jxf_do_step(jxf_instance *inst, const char *function, double t, double h) {
    const jxf_logger *log = inst ? &inst->log : NULL;
    const double end = t + h;
    double time;
    if (!jxf_allowed(inst, function, JXF_STEP)) return -1;
    if (!(isfinite(h) && h > 0.0) || !isfinite(t) || !isfinite(end)) {
        jxf_logf(log, JXF_LOG_ERROR, "doStep(currentCommunicationPoint = %g s, step = %g s): "
                 "the step must be a finite number > 0 ending at a finite time; state "
                 "unchanged", t, h);
        return -1;
    }
    if (!(end > t)) {
        jxf_logf(log, JXF_LOG_ERROR, "doStep(currentCommunicationPoint = %.17g s, step = %g s): "
                 "the step is below the resolution of the time in double precision, so the "
                 "time would not advance; state unchanged", t, h);
        return -1;
    }
    time = jxf_model_time(inst->model);
    if (fabs(t - time) > 1e-9 * (fabs(t) + h)) {
        jxf_logf(log, JXF_LOG_WARNING, "doStep: currentCommunicationPoint %.17g s differs from "
                 "the end of the previous step %.17g s; continuing from %.17g s", t, time, t);
    }
    return jxf_model_do_step(inst->model, t, h);
}

/* ---- variables ---------------------------------------------------------------------- */

int jxf_no_variables(jxf_instance *inst, const char *function, size_t n) {
    if (!jxf_allowed(inst, function, JXF_ANY_STATE)) return -1;
    if (n == 0) return 0;
    jxf_logf(&inst->log, JXF_LOG_ERROR, "%s: this FMU has no variables of this type", function);
    return -1;
}

int jxf_get_reals(jxf_instance *inst, const char *function, const unsigned vr[], size_t n_vr,
                  double values[], size_t n_values) {
    size_t i, k = 0;
    if (!jxf_allowed(inst, function, JXF_ANY_STATE)) return -1;
    for (i = 0; i < n_vr; ++i) {
        const size_t size = jxf_model_real_size(vr[i]);
        if (k + size > n_values) {
            jxf_logf(&inst->log, JXF_LOG_ERROR, "%s: nValues = %lu is too small for the "
                     "requested variables", function, (unsigned long)n_values);
            return -1;
        }
        if (jxf_model_get_real(inst->model, vr[i], values + k)) return -1;
        k += size;
    }
    if (k != n_values) {
        jxf_logf(&inst->log, JXF_LOG_ERROR, "%s: nValues = %lu, but the variables hold %lu "
                 "values", function, (unsigned long)n_values, (unsigned long)k);
        return -1;
    }
    return 0;
}

/* 0 if every variable is a scalar (n_vr == n_values), else -1 after logging. */
static int scalars_only(jxf_instance *inst, const char *function, size_t n_vr, size_t n_values) {
    if (n_values == n_vr) return 0;
    jxf_logf(&inst->log, JXF_LOG_ERROR, "%s: only scalar variables can be accessed here "
             "(nValues %lu != nValueReferences %lu)", function, (unsigned long)n_values,
             (unsigned long)n_vr);
    return -1;
}

int jxf_set_reals(jxf_instance *inst, const char *function, const unsigned vr[], size_t n_vr,
                  const double values[], size_t n_values) {
    size_t i;
    int apply;
    if (!jxf_allowed(inst, function, JXF_LIVE)) return -1;
    if (scalars_only(inst, function, n_vr, n_values)) return -1;
    for (apply = 0; apply < 2; ++apply) /* check all, then store all */
        for (i = 0; i < n_vr; ++i)
            if (jxf_model_set_real(inst->model, vr[i], values[i], apply)) return -1;
    return 0;
}

int jxf_get_output_rates(jxf_instance *inst, const char *function, const unsigned vr[],
                         size_t n_vr, const int orders[], double values[], size_t n_values) {
    size_t i;
    if (!jxf_allowed(inst, function, JXF_ANY_STATE)) return -1;
    if (scalars_only(inst, function, n_vr, n_values)) return -1;
    for (i = 0; i < n_vr; ++i)
        if (jxf_model_get_output_rate(inst->model, vr[i], orders[i], &values[i])) return -1;
    return 0;
}

int jxf_set_input_rates(jxf_instance *inst, const char *function, const unsigned vr[],
                        size_t n_vr, const int orders[], const double values[]) {
    size_t i;
    int apply;
    if (!jxf_allowed(inst, function, JXF_LIVE)) return -1;
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < n_vr; ++i)
            if (jxf_model_set_input_rate(inst->model, vr[i], orders[i], values[i], apply))
                return -1;
    return 0;
}

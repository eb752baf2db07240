/* FMI 2.0 co-simulation binding of every jaxflex FMU, over the instance of jxf_fmu.h (and so
 * over the core linked with it: the part, jxf_core.c, or the trajectory source,
 * jxf_source.c).
 *
 * Every FMI 2.0 function is exported; those that do not apply to a co-simulation FMU without
 * FMU-state support (model exchange, FMU state, directional derivatives, asynchronous steps)
 * log and return fmi2Error. Variable types an FMU does not have accept empty requests only.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "jxf_fmu.h"

typedef struct {
    jxf_instance core; /* first: the component is also a jxf_instance */
    fmi2CallbackFunctions callbacks;
    char *name;
} Instance;

#define INST(c) ((jxf_instance *)(c))
#define STATUS(result) ((result) == 0 ? fmi2OK : fmi2Error)

static void forward_log(void *context, int level, const char *message) {
    const Instance *inst = (const Instance *)context;
    fmi2Status status = level == JXF_LOG_ERROR ? fmi2Error
                        : level == JXF_LOG_WARNING ? fmi2Warning : fmi2OK;
    const char *category = level == JXF_LOG_ERROR ? "logStatusError"
                           : level == JXF_LOG_WARNING ? "logStatusWarning" : "logAll";
    if (inst->callbacks.logger != NULL)
        inst->callbacks.logger(inst->callbacks.componentEnvironment, inst->name, status, category,
                               "%s", message);
}

/* ---- common functions --------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    return STATUS(jxf_set_logging(INST(c), "fmi2SetDebugLogging", loggingOn != fmi2False,
                                  nCategories, categories));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    const char *name = instanceName ? instanceName : "";
    (void)visible;
    if (inst == NULL) return NULL;
    if (functions != NULL) inst->callbacks = *functions;
    inst->core.log.emit = forward_log;
    inst->core.log.context = inst;
    inst->core.log.debug = loggingOn != fmi2False;
    inst->name = (char *)malloc(strlen(name) + 1);
    if (inst->name != NULL) {
        strcpy(inst->name, name);
        if (fmuType != fmi2CoSimulation)
            jxf_logf(&inst->core.log, JXF_LOG_ERROR, "this FMU supports co-simulation only "
                     "(fmi2CoSimulation)");
        else if (jxf_instance_create(&inst->core, fmuResourceLocation, fmuGUID) == 0)
            return inst;
    }
    free(inst->name);
    free(inst);
    return NULL;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    jxf_instance_free(&inst->core);
    free(inst->name);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return STATUS(jxf_setup(INST(c), "fmi2SetupExperiment", startTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return STATUS(jxf_enter_initialization(INST(c), "fmi2EnterInitializationMode"));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return STATUS(jxf_exit_initialization(INST(c), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c) { return STATUS(jxf_terminate(INST(c), "fmi2Terminate")); }

fmi2Status fmi2Reset(fmi2Component c) { return STATUS(jxf_reset(INST(c), "fmi2Reset")); }

/* ---- variables ---------------------------------------------------------------------- */

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    return STATUS(jxf_get_reals(INST(c), "fmi2GetReal", vr, nvr, value, nvr));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    return STATUS(jxf_set_reals(INST(c), "fmi2SetReal", vr, nvr, value, nvr));
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    size_t i;
    int flag;
    if (!jxf_allowed(INST(c), "fmi2GetBoolean", JXF_ANY_STATE)) return fmi2Error;
    for (i = 0; i < nvr; ++i) {
        if (jxf_model_get_bool(INST(c)->model, vr[i], &flag)) return fmi2Error;
        value[i] = flag ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    size_t i;
    int apply;
    if (!jxf_allowed(INST(c), "fmi2SetBoolean", JXF_LIVE)) return fmi2Error;
    for (apply = 0; apply < 2; ++apply) /* check all, then store all */
        for (i = 0; i < nvr; ++i)
            if (jxf_model_set_bool(INST(c)->model, vr[i], value[i] != fmi2False, apply))
                return fmi2Error;
    return fmi2OK;
}

JXF_SIGNATURES_BEGIN

#define NO_VARIABLES(name, ...)                                                       \
    fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,      \
                    __VA_ARGS__) {                                                    \
        return STATUS(jxf_no_variables(INST(c), #name, nvr));                         \
    }

NO_VARIABLES(fmi2GetInteger, fmi2Integer value[])
NO_VARIABLES(fmi2SetInteger, const fmi2Integer value[])
NO_VARIABLES(fmi2GetString, fmi2String value[])
NO_VARIABLES(fmi2SetString, const fmi2String value[])

/* ---- co-simulation ------------------------------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    return STATUS(jxf_set_input_rates(INST(c), "fmi2SetRealInputDerivatives", vr, nvr, order,
                                      value));
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    return STATUS(jxf_get_output_rates(INST(c), "fmi2GetRealOutputDerivatives", vr, nvr, order,
                                       value, nvr));
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    return STATUS(jxf_do_step(INST(c), "fmi2DoStep", currentCommunicationPoint,
                              communicationStepSize));
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (!jxf_allowed(INST(c), "fmi2GetRealStatus", JXF_ANY_STATE)) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return STATUS(jxf_unsupported(INST(c), "fmi2GetRealStatus "
                                                                   "(this kind)"));
    *value = jxf_model_time(INST(c)->model);
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (!jxf_allowed(INST(c), "fmi2GetBooleanStatus", JXF_ANY_STATE)) return fmi2Error;
    if (s != fmi2Terminated) return STATUS(jxf_unsupported(INST(c), "fmi2GetBooleanStatus "
                                                           "(this kind)"));
    *value = fmi2False;
    return fmi2OK;
}

/* ---- functions that do not apply ---------------------------------------------------- */

#define UNSUPPORTED(name, why, ...)                                                   \
    fmi2Status name(fmi2Component c, __VA_ARGS__) {                                   \
        return STATUS(jxf_unsupported(INST(c), #name " (" why ")"));                  \
    }
#define UNSUPPORTED0(name, why)                                                       \
    fmi2Status name(fmi2Component c) {                                                \
        return STATUS(jxf_unsupported(INST(c), #name " (" why ")"));                  \
    }
#define ME "model exchange"

UNSUPPORTED0(fmi2CancelStep, "doStep never returns fmi2Pending")
UNSUPPORTED(fmi2GetStatus, "doStep is synchronous", const fmi2StatusKind s, fmi2Status *value)
UNSUPPORTED(fmi2GetIntegerStatus, "no such status", const fmi2StatusKind s, fmi2Integer *value)
UNSUPPORTED(fmi2GetStringStatus, "no such status", const fmi2StatusKind s, fmi2String *value)
JXF_NO_FMU_STATE(fmi2, s, fmi2DeSerializeFMUstate)
UNSUPPORTED(fmi2GetDirectionalDerivative, "providesDirectionalDerivative is false",
            const fmi2ValueReference unknown[], size_t n_unknown,
            const fmi2ValueReference known[], size_t n_known, const fmi2Real seed[],
            fmi2Real sensitivity[])
UNSUPPORTED0(fmi2EnterEventMode, ME)
UNSUPPORTED(fmi2NewDiscreteStates, ME, fmi2EventInfo *info)
UNSUPPORTED0(fmi2EnterContinuousTimeMode, ME)
UNSUPPORTED(fmi2CompletedIntegratorStep, ME, fmi2Boolean no_set_state, fmi2Boolean *enter_event,
            fmi2Boolean *terminate)
UNSUPPORTED(fmi2SetTime, ME, fmi2Real time)
UNSUPPORTED(fmi2SetContinuousStates, ME, const fmi2Real x[], size_t nx)
UNSUPPORTED(fmi2GetDerivatives, ME, fmi2Real derivatives[], size_t nx)
UNSUPPORTED(fmi2GetEventIndicators, ME, fmi2Real indicators[], size_t ni)
UNSUPPORTED(fmi2GetContinuousStates, ME, fmi2Real x[], size_t nx)
UNSUPPORTED(fmi2GetNominalsOfContinuousStates, ME, fmi2Real nominals[], size_t nx)

JXF_SIGNATURES_END

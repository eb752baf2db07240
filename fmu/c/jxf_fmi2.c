/* FMI 2.0 co-simulation interface of the jaxflex FMU core (jxf_core.h).
 *
 * Inputs ax, ay, az (m/s^2) are linear over a communication step when the importer sets
 * their time derivatives with fmi2SetRealInputDerivatives (order 1; they stay in effect until
 * set again) and held over the step otherwise. Every FMI 2.0 function is exported; those that
 * do not apply to a co-simulation FMU without FMU-state support log and return fmi2Error.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "jxf_core.h"

typedef struct {
    jxf_model *model;
    fmi2CallbackFunctions callbacks;
    char *name;
} Instance;

#define MODEL(c) ((c) != NULL ? ((Instance *)(c))->model : NULL)
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

static char *copy_string(const char *s) {
    const char *text = s ? s : "";
    char *out = (char *)malloc(strlen(text) + 1);
    if (out) strcpy(out, text);
    return out;
}

static fmi2Status unsupported(fmi2Component c, const char *function) {
    jxf_unsupported(MODEL(c), function);
    return fmi2Error;
}

/* ---- common functions --------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    return STATUS(jxf_set_logging(MODEL(c), "fmi2SetDebugLogging", loggingOn != fmi2False,
                                  nCategories, categories));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    (void)visible;
    if (inst == NULL) return NULL;
    if (functions != NULL) inst->callbacks = *functions;
    inst->name = copy_string(instanceName);
    if (inst->name == NULL) {
        free(inst);
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        forward_log(inst, JXF_LOG_ERROR, "this FMU supports co-simulation only (fmi2CoSimulation)");
    } else {
        inst->model = jxf_create(fmuResourceLocation, fmuGUID, forward_log, inst,
                                 loggingOn != fmi2False);
    }
    if (inst->model == NULL) {
        free(inst->name);
        free(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    jxf_destroy(inst->model);
    free(inst->name);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return STATUS(jxf_setup(MODEL(c), "fmi2SetupExperiment", startTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return STATUS(jxf_enter_initialization(MODEL(c), "fmi2EnterInitializationMode"));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return STATUS(jxf_exit_initialization(MODEL(c), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c) {
    return STATUS(jxf_terminate(MODEL(c), "fmi2Terminate"));
}

fmi2Status fmi2Reset(fmi2Component c) { return STATUS(jxf_reset(MODEL(c), "fmi2Reset")); }

/* ---- variables ---------------------------------------------------------------------- */

static fmi2Status no_variables(fmi2Component c, const char *function, size_t nvr) {
    if (!jxf_allowed(MODEL(c), function, JXF_ANY_STATE)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    jxf_log(MODEL(c), JXF_LOG_ERROR, "%s: this FMU has no variables of this type", function);
    return fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    jxf_model *m = MODEL(c);
    size_t i;
    if (!jxf_allowed(m, "fmi2GetReal", JXF_ANY_STATE)) return fmi2Error;
    for (i = 0; i < nvr; ++i)
        if (jxf_get_real(m, vr[i], &value[i])) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    jxf_model *m = MODEL(c);
    size_t i;
    int apply;
    if (!jxf_allowed(m, "fmi2SetReal", JXF_LIVE)) return fmi2Error;
    /* check all, then store all: a rejected call changes nothing */
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < nvr; ++i)
            if (jxf_set_real(m, vr[i], value[i], apply)) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    jxf_model *m = MODEL(c);
    size_t i;
    int flag;
    if (!jxf_allowed(m, "fmi2GetBoolean", JXF_ANY_STATE)) return fmi2Error;
    for (i = 0; i < nvr; ++i) {
        if (jxf_get_bool(m, vr[i], &flag)) return fmi2Error;
        value[i] = flag ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    jxf_model *m = MODEL(c);
    size_t i;
    int apply;
    if (!jxf_allowed(m, "fmi2SetBoolean", JXF_LIVE)) return fmi2Error;
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < nvr; ++i)
            if (jxf_set_bool(m, vr[i], value[i] != fmi2False, apply)) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    (void)vr, (void)value;
    return no_variables(c, "fmi2GetInteger", nvr);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)vr, (void)value;
    return no_variables(c, "fmi2SetInteger", nvr);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr, (void)value;
    return no_variables(c, "fmi2GetString", nvr);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr, (void)value;
    return no_variables(c, "fmi2SetString", nvr);
}

/* ---- co-simulation ------------------------------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    jxf_model *m = MODEL(c);
    size_t i;
    int apply;
    if (!jxf_allowed(m, "fmi2SetRealInputDerivatives", JXF_LIVE)) return fmi2Error;
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < nvr; ++i)
            if (jxf_set_input_rate(m, vr[i], order[i], value[i], apply)) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    jxf_model *m = MODEL(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!jxf_allowed(m, "fmi2DoStep", JXF_STEP)) return fmi2Error;
    return STATUS(jxf_do_step(m, currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    jxf_model *m = MODEL(c);
    if (!jxf_allowed(m, "fmi2GetRealStatus", JXF_ANY_STATE)) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return unsupported(c, "fmi2GetRealStatus (this kind)");
    *value = m->time;
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (!jxf_allowed(MODEL(c), "fmi2GetBooleanStatus", JXF_ANY_STATE)) return fmi2Error;
    if (s != fmi2Terminated) return unsupported(c, "fmi2GetBooleanStatus (this kind)");
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder is 0)");
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return unsupported(c, "fmi2CancelStep (doStep never returns fmi2Pending)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    return unsupported(c, "fmi2GetStatus (doStep is synchronous)");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    return unsupported(c, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    return unsupported(c, "fmi2GetStringStatus");
}

/* ---- functions that do not apply (FMU state, derivatives, model exchange) ----------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    return unsupported(c, "fmi2GetFMUstate (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    (void)FMUstate;
    return unsupported(c, "fmi2SetFMUstate (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    return unsupported(c, "fmi2FreeFMUstate (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate, (void)size;
    return unsupported(c, "fmi2SerializedFMUstateSize (canSerializeFMUstate is false)");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size) {
    (void)FMUstate, (void)serializedState, (void)size;
    return unsupported(c, "fmi2SerializeFMUstate (canSerializeFMUstate is false)");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate) {
    (void)serializedState, (void)size, (void)FMUstate;
    return unsupported(c, "fmi2DeSerializeFMUstate (canSerializeFMUstate is false)");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown;
    (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative (providesDirectionalDerivative is false)");
}

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    return unsupported(c, "fmi2EnterEventMode (model exchange)");
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    (void)eventInfo;
    return unsupported(c, "fmi2NewDiscreteStates (model exchange)");
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    return unsupported(c, "fmi2EnterContinuousTimeMode (model exchange)");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    return unsupported(c, "fmi2CompletedIntegratorStep (model exchange)");
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    (void)time;
    return unsupported(c, "fmi2SetTime (model exchange)");
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    (void)x, (void)nx;
    return unsupported(c, "fmi2SetContinuousStates (model exchange)");
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    (void)derivatives, (void)nx;
    return unsupported(c, "fmi2GetDerivatives (model exchange)");
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    (void)eventIndicators, (void)ni;
    return unsupported(c, "fmi2GetEventIndicators (model exchange)");
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    (void)x, (void)nx;
    return unsupported(c, "fmi2GetContinuousStates (model exchange)");
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    (void)x_nominal, (void)nx;
    return unsupported(c, "fmi2GetNominalsOfContinuousStates (model exchange)");
}

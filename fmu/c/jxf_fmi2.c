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

typedef enum { ST_INSTANTIATED, ST_INITIALIZATION, ST_STEP, ST_TERMINATED } State;

typedef struct {
    jxf_model *model;
    fmi2CallbackFunctions callbacks;
    char *name;
    State state;
    double start_time;
} Instance;

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

/* Log an error for a call that is not allowed in the current state. */
static int allowed(Instance *inst, const char *function, int mask) {
    if (inst == NULL) return 0;
    if (mask & (1 << inst->state)) return 1;
    jxf_log(inst->model, JXF_LOG_ERROR, "%s is not allowed in the current state", function);
    return 0;
}

#define ANY_STATE 0xF
#define BEFORE_RUN ((1 << ST_INSTANTIATED) | (1 << ST_INITIALIZATION))
#define LIVE ((1 << ST_INSTANTIATED) | (1 << ST_INITIALIZATION) | (1 << ST_STEP))

static fmi2Status unsupported(fmi2Component c, const char *function) {
    Instance *inst = (Instance *)c;
    if (inst != NULL)
        jxf_log(inst->model, JXF_LOG_ERROR, "%s is not supported by this co-simulation FMU",
                function);
    return fmi2Error;
}

/* ---- common functions --------------------------------------------------------------- */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    static const char *known[] = {"logStatusError", "logStatusWarning", "logAll"};
    Instance *inst = (Instance *)c;
    size_t i;
    int k, found;
    if (!allowed(inst, "fmi2SetDebugLogging", ANY_STATE)) return fmi2Error;
    for (i = 0; i < nCategories; ++i) {
        for (found = 0, k = 0; k < 3; ++k) found |= categories[i] && !strcmp(categories[i], known[k]);
        if (!found) {
            jxf_log(inst->model, JXF_LOG_ERROR, "fmi2SetDebugLogging: unknown log category '%s' "
                    "(known: logStatusError, logStatusWarning, logAll)",
                    categories[i] ? categories[i] : "(null)");
            return fmi2Error;
        }
    }
    inst->model->debug = loggingOn != fmi2False;
    return fmi2OK;
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
    inst->state = ST_INSTANTIATED;
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
    Instance *inst = (Instance *)c;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!allowed(inst, "fmi2SetupExperiment", 1 << ST_INSTANTIATED)) return fmi2Error;
    if (!isfinite(startTime)) {
        jxf_log(inst->model, JXF_LOG_ERROR, "fmi2SetupExperiment: startTime %g is not finite",
                startTime);
        return fmi2Error;
    }
    inst->start_time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!allowed(inst, "fmi2EnterInitializationMode", 1 << ST_INSTANTIATED)) return fmi2Error;
    inst->state = ST_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!allowed(inst, "fmi2ExitInitializationMode", 1 << ST_INITIALIZATION)) return fmi2Error;
    jxf_start(inst->model, inst->start_time);
    inst->state = ST_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!allowed(inst, "fmi2Terminate", 1 << ST_STEP)) return fmi2Error;
    inst->state = ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (!allowed(inst, "fmi2Reset", ANY_STATE)) return fmi2Error;
    jxf_reset(inst->model);
    inst->start_time = 0.0;
    inst->state = ST_INSTANTIATED;
    return fmi2OK;
}

/* ---- variables ---------------------------------------------------------------------- */

static fmi2Status no_variables(fmi2Component c, const char *function, size_t nvr) {
    Instance *inst = (Instance *)c;
    if (!allowed(inst, function, ANY_STATE)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    jxf_log(inst->model, JXF_LOG_ERROR, "%s: this FMU has no variables of this type", function);
    return fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    if (!allowed(inst, "fmi2GetReal", ANY_STATE)) return fmi2Error;
    for (i = 0; i < nvr; ++i)
        if (jxf_get_real(inst->model, vr[i], &value[i])) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    int apply;
    if (!allowed(inst, "fmi2SetReal", LIVE)) return fmi2Error;
    for (apply = 0; apply < 2; ++apply) /* check all, then store all: a rejected call changes nothing */
        for (i = 0; i < nvr; ++i)
            if (jxf_set_real(inst->model, vr[i], value[i], apply)) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    int flag;
    if (!allowed(inst, "fmi2GetBoolean", ANY_STATE)) return fmi2Error;
    for (i = 0; i < nvr; ++i) {
        if (jxf_get_bool(inst->model, vr[i], &flag)) return fmi2Error;
        value[i] = flag ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    Instance *inst = (Instance *)c;
    size_t i;
    int apply;
    if (!allowed(inst, "fmi2SetBoolean", LIVE)) return fmi2Error;
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < nvr; ++i)
            if (jxf_set_bool(inst->model, vr[i], value[i] != fmi2False, apply)) return fmi2Error;
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
    Instance *inst = (Instance *)c;
    size_t i;
    int apply;
    if (!allowed(inst, "fmi2SetRealInputDerivatives", LIVE)) return fmi2Error;
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < nvr; ++i)
            if (jxf_set_input_rate(inst->model, vr[i], order[i], value[i], apply))
                return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *inst = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(inst, "fmi2DoStep", 1 << ST_STEP)) return fmi2Error;
    return jxf_do_step(inst->model, currentCommunicationPoint, communicationStepSize) ? fmi2Error
                                                                                       : fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *inst = (Instance *)c;
    if (!allowed(inst, "fmi2GetRealStatus", ANY_STATE)) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return unsupported(c, "fmi2GetRealStatus (this kind)");
    *value = inst->model->time;
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    if (!allowed((Instance *)c, "fmi2GetBooleanStatus", ANY_STATE)) return fmi2Error;
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

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
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

/* FMI 2.0 co-simulation interface of the trajectory source (jxf_source.h).
 *
 * Outputs ax, ay, az (value references 1-3, m/s^2) and their first derivatives through
 * fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder = 1). Every FMI 2.0 function is
 * exported; those that do not apply log and return fmi2Error.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "jxf_source.h"

typedef struct {
    jxf_source source;
    fmi2CallbackFunctions callbacks;
    char *name;
} Instance;

#define SOURCE(c) ((c) != NULL ? &((Instance *)(c))->source : NULL)
#define STATUS(result) ((result) == 0 ? fmi2OK : fmi2Error)

static void forward_log(void *context, int level, const char *message) {
    const Instance *inst = (const Instance *)context;
    fmi2Status status = level == JXF_SOURCE_ERROR ? fmi2Error
                        : level == JXF_SOURCE_WARNING ? fmi2Warning : fmi2OK;
    const char *category = level == JXF_SOURCE_ERROR ? "logStatusError"
                           : level == JXF_SOURCE_WARNING ? "logStatusWarning" : "logAll";
    if (inst->callbacks.logger != NULL)
        inst->callbacks.logger(inst->callbacks.componentEnvironment, inst->name, status, category,
                               "%s", message);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories, (void)categories;
    return STATUS(jxf_source_set_logging(SOURCE(c), "fmi2SetDebugLogging", loggingOn != 0));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    const char *name = instanceName ? instanceName : "";
    (void)fmuResourceLocation, (void)visible;
    if (inst == NULL) return NULL;
    if (functions != NULL) inst->callbacks = *functions;
    inst->name = (char *)malloc(strlen(name) + 1);
    if (inst->name == NULL) {
        free(inst);
        return NULL;
    }
    strcpy(inst->name, name);
    if (fmuType != fmi2CoSimulation) {
        forward_log(inst, JXF_SOURCE_ERROR, "this FMU supports co-simulation only");
    } else if (jxf_source_init(&inst->source, fmuGUID, forward_log, inst, loggingOn != 0) == 0) {
        return inst;
    }
    free(inst->name);
    free(inst);
    return NULL;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *inst = (Instance *)c;
    if (inst == NULL) return;
    free(inst->name);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return STATUS(jxf_source_setup(SOURCE(c), "fmi2SetupExperiment", startTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return STATUS(jxf_source_enter_initialization(SOURCE(c), "fmi2EnterInitializationMode"));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return STATUS(jxf_source_exit_initialization(SOURCE(c), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component c) {
    return STATUS(jxf_source_terminate(SOURCE(c), "fmi2Terminate"));
}

fmi2Status fmi2Reset(fmi2Component c) {
    return STATUS(jxf_source_reset(SOURCE(c), "fmi2Reset"));
}

/* order[i] = 0 reads values (fmi2GetReal), 1 the first derivatives. */
static fmi2Status get_reals(fmi2Component c, const char *function, const fmi2ValueReference vr[],
                            size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    jxf_source *s = SOURCE(c);
    size_t i;
    if (!jxf_source_allowed(s, function, JXF_SOURCE_ANY_STATE)) return fmi2Error;
    for (i = 0; i < nvr; ++i)
        if (jxf_source_get(s, vr[i], order ? order[i] : 0, &value[i])) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    return get_reals(c, "fmi2GetReal", vr, nvr, NULL, value);
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    return get_reals(c, "fmi2GetRealOutputDerivatives", vr, nvr, order, value);
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    jxf_source *s = SOURCE(c);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!jxf_source_allowed(s, "fmi2DoStep", JXF_SOURCE_STEP)) return fmi2Error;
    return STATUS(jxf_source_do_step(s, currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    jxf_source *src = SOURCE(c);
    if (!jxf_source_allowed(src, "fmi2GetRealStatus", JXF_SOURCE_ANY_STATE)) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) {
        jxf_source_unsupported(src, "fmi2GetRealStatus (this kind)");
        return fmi2Error;
    }
    *value = src->time;
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    jxf_source *src = SOURCE(c);
    if (!jxf_source_allowed(src, "fmi2GetBooleanStatus", JXF_SOURCE_ANY_STATE)) return fmi2Error;
    if (s != fmi2Terminated) {
        jxf_source_unsupported(src, "fmi2GetBooleanStatus (this kind)");
        return fmi2Error;
    }
    *value = fmi2False;
    return fmi2OK;
}

/* ---- variables this FMU does not have and functions that do not apply ---------------- */

/* Generated definitions: unused parameters are part of the standard's signatures. */
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif

/* Fine for an empty request, an error otherwise (no writable variables of any type). */
#define NO_VARIABLES(name, ...)                                                            \
    fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,           \
                    __VA_ARGS__) {                                                         \
        if (!jxf_source_allowed(SOURCE(c), #name, JXF_SOURCE_ANY_STATE)) return fmi2Error; \
        if (nvr == 0) return fmi2OK;                                                       \
        jxf_source_log(SOURCE(c), JXF_SOURCE_ERROR, "%s: no such variable (value "         \
                       "reference %u)", #name, vr[0]);                                     \
        return fmi2Error;                                                                  \
    }

NO_VARIABLES(fmi2SetReal, const fmi2Real value[])
NO_VARIABLES(fmi2GetInteger, fmi2Integer value[])
NO_VARIABLES(fmi2SetInteger, const fmi2Integer value[])
NO_VARIABLES(fmi2GetBoolean, fmi2Boolean value[])
NO_VARIABLES(fmi2SetBoolean, const fmi2Boolean value[])
NO_VARIABLES(fmi2GetString, fmi2String value[])
NO_VARIABLES(fmi2SetString, const fmi2String value[])
NO_VARIABLES(fmi2SetRealInputDerivatives, const fmi2Integer order[], const fmi2Real value[])

#define UNSUPPORTED(name, ...)                                \
    fmi2Status name(fmi2Component c, __VA_ARGS__) {           \
        jxf_source_unsupported(SOURCE(c), #name);             \
        return fmi2Error;                                     \
    }
#define UNSUPPORTED0(name)                                    \
    fmi2Status name(fmi2Component c) {                        \
        jxf_source_unsupported(SOURCE(c), #name);             \
        return fmi2Error;                                     \
    }

UNSUPPORTED(fmi2GetFMUstate, fmi2FMUstate *state)
UNSUPPORTED(fmi2SetFMUstate, fmi2FMUstate state)
UNSUPPORTED(fmi2FreeFMUstate, fmi2FMUstate *state)
UNSUPPORTED(fmi2SerializedFMUstateSize, fmi2FMUstate state, size_t *size)
UNSUPPORTED(fmi2SerializeFMUstate, fmi2FMUstate state, fmi2Byte serialized[], size_t size)
UNSUPPORTED(fmi2DeSerializeFMUstate, const fmi2Byte serialized[], size_t size,
            fmi2FMUstate *state)
UNSUPPORTED(fmi2GetDirectionalDerivative, const fmi2ValueReference unknown[], size_t n_unknown,
            const fmi2ValueReference known[], size_t n_known, const fmi2Real seed[],
            fmi2Real sensitivity[])
UNSUPPORTED0(fmi2EnterEventMode)
UNSUPPORTED(fmi2NewDiscreteStates, fmi2EventInfo *info)
UNSUPPORTED0(fmi2EnterContinuousTimeMode)
UNSUPPORTED(fmi2CompletedIntegratorStep, fmi2Boolean no_set_state, fmi2Boolean *enter_event,
            fmi2Boolean *terminate)
UNSUPPORTED(fmi2SetTime, fmi2Real time)
UNSUPPORTED(fmi2SetContinuousStates, const fmi2Real x[], size_t nx)
UNSUPPORTED(fmi2GetDerivatives, fmi2Real derivatives[], size_t nx)
UNSUPPORTED(fmi2GetEventIndicators, fmi2Real indicators[], size_t ni)
UNSUPPORTED(fmi2GetContinuousStates, fmi2Real x[], size_t nx)
UNSUPPORTED(fmi2GetNominalsOfContinuousStates, fmi2Real nominals[], size_t nx)
UNSUPPORTED0(fmi2CancelStep)
UNSUPPORTED(fmi2GetStatus, const fmi2StatusKind s, fmi2Status *value)
UNSUPPORTED(fmi2GetIntegerStatus, const fmi2StatusKind s, fmi2Integer *value)
UNSUPPORTED(fmi2GetStringStatus, const fmi2StatusKind s, fmi2String *value)

#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

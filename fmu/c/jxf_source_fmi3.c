/* FMI 3.0 co-simulation interface of the trajectory source (jxf_source.h).
 *
 * Outputs ax, ay, az (value references 1-3, m/s^2) and their first derivatives through
 * fmi3GetOutputDerivatives (maxOutputDerivativeOrder = 1; FMI 3.0 has no input derivatives,
 * so an importer can only use them for its own extrapolation). Every FMI 3.0 function is
 * exported; those that do not apply log and return fmi3Error.
 */
#include <stdlib.h>

#include "fmi3Functions.h"
#include "jxf_source.h"

typedef struct {
    jxf_source source;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Instance;

#define SOURCE(c) ((c) != NULL ? &((Instance *)(c))->source : NULL)
#define STATUS(result) ((result) == 0 ? fmi3OK : fmi3Error)

static void forward_log(void *context, int level, const char *message) {
    const Instance *inst = (const Instance *)context;
    fmi3Status status = level == JXF_SOURCE_ERROR ? fmi3Error
                        : level == JXF_SOURCE_WARNING ? fmi3Warning : fmi3OK;
    const char *category = level == JXF_SOURCE_ERROR ? "logStatusError"
                           : level == JXF_SOURCE_WARNING ? "logStatusWarning" : "logAll";
    if (inst->log_message != NULL) inst->log_message(inst->environment, status, category, message);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    (void)nCategories, (void)categories;
    return STATUS(jxf_source_set_logging(SOURCE(instance), "fmi3SetDebugLogging", loggingOn));
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    (void)instanceName, (void)resourcePath, (void)visible, (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables, (void)intermediateUpdate;
    if (inst == NULL) return NULL;
    inst->environment = instanceEnvironment;
    inst->log_message = logMessage;
    if (eventModeUsed) {
        forward_log(inst, JXF_SOURCE_ERROR, "event mode is not supported (hasEventMode is false)");
    } else if (nRequiredIntermediateVariables > 0) {
        forward_log(inst, JXF_SOURCE_ERROR, "intermediate variables are not supported");
    } else if (jxf_source_init(&inst->source, instantiationToken, forward_log, inst, loggingOn) ==
               0) {
        return inst;
    }
    free(inst);
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    jxf_source *s = SOURCE(instance);
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return STATUS(jxf_source_setup(s, "fmi3EnterInitializationMode", startTime) ||
                  jxf_source_enter_initialization(s, "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return STATUS(jxf_source_exit_initialization(SOURCE(instance), "fmi3ExitInitializationMode"));
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    return STATUS(jxf_source_terminate(SOURCE(instance), "fmi3Terminate"));
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    return STATUS(jxf_source_reset(SOURCE(instance), "fmi3Reset"));
}

/* orders[i] = 0 reads values (fmi3GetFloat64), 1 the first derivatives; scalars only. */
static fmi3Status get_floats(fmi3Instance instance, const char *function,
                             const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 orders[],
                             fmi3Float64 values[], size_t nValues) {
    jxf_source *s = SOURCE(instance);
    size_t i;
    if (!jxf_source_allowed(s, function, JXF_SOURCE_ANY_STATE)) return fmi3Error;
    if (nValues != nvr) {
        jxf_source_log(s, JXF_SOURCE_ERROR, "%s: nValues %lu != nValueReferences %lu (all "
                       "variables are scalars)", function, (unsigned long)nValues,
                       (unsigned long)nvr);
        return fmi3Error;
    }
    for (i = 0; i < nvr; ++i)
        if (jxf_source_get(s, vr[i], orders ? orders[i] : 0, &values[i])) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    return get_floats(instance, "fmi3GetFloat64", valueReferences, nValueReferences, NULL, values,
                      nValues);
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    return get_floats(instance, "fmi3GetOutputDerivatives", vr, nvr, orders, values, nValues);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    jxf_source *s = SOURCE(instance);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!jxf_source_allowed(s, "fmi3DoStep", JXF_SOURCE_STEP)) return fmi3Error;
    if (jxf_source_do_step(s, currentCommunicationPoint, communicationStepSize)) return fmi3Error;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = s->time;
    return fmi3OK;
}

/* ---- variables this FMU does not have and functions that do not apply ---------------- */

/* Generated definitions: unused parameters are part of the standard's signatures. */
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName,
                                          fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU supports co-simulation only (no model exchange)");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU supports co-simulation only (no scheduled execution)");
    return NULL;
}

/* Fine for an empty request, an error otherwise (no writable variables of any type). */
#define NO_VARIABLES(name, ...)                                                              \
    fmi3Status name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,       \
                    __VA_ARGS__) {                                                           \
        if (!jxf_source_allowed(SOURCE(instance), #name, JXF_SOURCE_ANY_STATE))              \
            return fmi3Error;                                                                \
        if (nvr == 0) return fmi3OK;                                                         \
        jxf_source_log(SOURCE(instance), JXF_SOURCE_ERROR, "%s: no such variable (value "    \
                       "reference %u)", #name, vr[0]);                                       \
        return fmi3Error;                                                                    \
    }
#define NO_GET_SET(Type)                                                                     \
    NO_VARIABLES(fmi3Get##Type, fmi3##Type values[], size_t nValues)                         \
    NO_VARIABLES(fmi3Set##Type, const fmi3##Type values[], size_t nValues)

NO_VARIABLES(fmi3SetFloat64, const fmi3Float64 values[], size_t nValues)
NO_GET_SET(Float32)
NO_GET_SET(Int8)
NO_GET_SET(UInt8)
NO_GET_SET(Int16)
NO_GET_SET(UInt16)
NO_GET_SET(Int32)
NO_GET_SET(UInt32)
NO_GET_SET(Int64)
NO_GET_SET(UInt64)
NO_GET_SET(Boolean)
NO_GET_SET(String)
NO_VARIABLES(fmi3GetBinary, size_t sizes[], fmi3Binary values[], size_t nValues)
NO_VARIABLES(fmi3SetBinary, const size_t sizes[], const fmi3Binary values[], size_t nValues)
NO_VARIABLES(fmi3GetClock, fmi3Clock values[])
NO_VARIABLES(fmi3SetClock, const fmi3Clock values[])

#define UNSUPPORTED(name, ...)                                \
    fmi3Status name(fmi3Instance instance, __VA_ARGS__) {     \
        jxf_source_unsupported(SOURCE(instance), #name);      \
        return fmi3Error;                                     \
    }
#define UNSUPPORTED0(name)                                    \
    fmi3Status name(fmi3Instance instance) {                  \
        jxf_source_unsupported(SOURCE(instance), #name);      \
        return fmi3Error;                                     \
    }

UNSUPPORTED0(fmi3EnterEventMode)
UNSUPPORTED0(fmi3EnterStepMode)
UNSUPPORTED(fmi3GetNumberOfVariableDependencies, fmi3ValueReference vr, size_t *n)
UNSUPPORTED(fmi3GetVariableDependencies, fmi3ValueReference dependent, size_t element_dep[],
            fmi3ValueReference independents[], size_t element_ind[], fmi3DependencyKind kinds[],
            size_t n)
UNSUPPORTED(fmi3GetFMUState, fmi3FMUState *state)
UNSUPPORTED(fmi3SetFMUState, fmi3FMUState state)
UNSUPPORTED(fmi3FreeFMUState, fmi3FMUState *state)
UNSUPPORTED(fmi3SerializedFMUStateSize, fmi3FMUState state, size_t *size)
UNSUPPORTED(fmi3SerializeFMUState, fmi3FMUState state, fmi3Byte serialized[], size_t size)
UNSUPPORTED(fmi3DeserializeFMUState, const fmi3Byte serialized[], size_t size,
            fmi3FMUState *state)
UNSUPPORTED(fmi3GetDirectionalDerivative, const fmi3ValueReference unknowns[], size_t n_unknowns,
            const fmi3ValueReference knowns[], size_t n_knowns, const fmi3Float64 seed[],
            size_t n_seed, fmi3Float64 sensitivity[], size_t n_sensitivity)
UNSUPPORTED(fmi3GetAdjointDerivative, const fmi3ValueReference unknowns[], size_t n_unknowns,
            const fmi3ValueReference knowns[], size_t n_knowns, const fmi3Float64 seed[],
            size_t n_seed, fmi3Float64 sensitivity[], size_t n_sensitivity)
UNSUPPORTED0(fmi3EnterConfigurationMode)
UNSUPPORTED0(fmi3ExitConfigurationMode)
UNSUPPORTED(fmi3GetIntervalDecimal, const fmi3ValueReference vr[], size_t nvr,
            fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
UNSUPPORTED(fmi3GetIntervalFraction, const fmi3ValueReference vr[], size_t nvr,
            fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
UNSUPPORTED(fmi3GetShiftDecimal, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[])
UNSUPPORTED(fmi3GetShiftFraction, const fmi3ValueReference vr[], size_t nvr,
            fmi3UInt64 counters[], fmi3UInt64 resolutions[])
UNSUPPORTED(fmi3SetIntervalDecimal, const fmi3ValueReference vr[], size_t nvr,
            const fmi3Float64 intervals[])
UNSUPPORTED(fmi3SetIntervalFraction, const fmi3ValueReference vr[], size_t nvr,
            const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
UNSUPPORTED(fmi3SetShiftDecimal, const fmi3ValueReference vr[], size_t nvr,
            const fmi3Float64 shifts[])
UNSUPPORTED(fmi3SetShiftFraction, const fmi3ValueReference vr[], size_t nvr,
            const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
UNSUPPORTED0(fmi3EvaluateDiscreteStates)
UNSUPPORTED(fmi3UpdateDiscreteStates, fmi3Boolean *need_update, fmi3Boolean *terminate,
            fmi3Boolean *nominals_changed, fmi3Boolean *values_changed,
            fmi3Boolean *next_event_defined, fmi3Float64 *next_event_time)
UNSUPPORTED0(fmi3EnterContinuousTimeMode)
UNSUPPORTED(fmi3CompletedIntegratorStep, fmi3Boolean no_set_state, fmi3Boolean *enter_event,
            fmi3Boolean *terminate)
UNSUPPORTED(fmi3SetTime, fmi3Float64 time)
UNSUPPORTED(fmi3SetContinuousStates, const fmi3Float64 x[], size_t nx)
UNSUPPORTED(fmi3GetContinuousStateDerivatives, fmi3Float64 derivatives[], size_t nx)
UNSUPPORTED(fmi3GetEventIndicators, fmi3Float64 indicators[], size_t ni)
UNSUPPORTED(fmi3GetContinuousStates, fmi3Float64 x[], size_t nx)
UNSUPPORTED(fmi3GetNominalsOfContinuousStates, fmi3Float64 nominals[], size_t nx)
UNSUPPORTED(fmi3GetNumberOfEventIndicators, size_t *n)
UNSUPPORTED(fmi3GetNumberOfContinuousStates, size_t *n)
UNSUPPORTED(fmi3ActivateModelPartition, fmi3ValueReference clock, fmi3Float64 activation_time)

#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

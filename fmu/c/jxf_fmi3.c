/* FMI 3.0 co-simulation binding of every jaxflex FMU, over the instance of jxf_fmu.h (and so
 * over the core linked with it: the part, jxf_core.c, or the trajectory source,
 * jxf_source.c).
 *
 * FMI 3.0 has no input derivatives: inputs are held over a communication step. Float64
 * variables may be arrays (the part's K x 3 points). Every FMI 3.0 function is exported;
 * those that do not apply (model exchange, scheduled execution, clocks, FMU state,
 * derivatives) log and return fmi3Error, and the two other kinds of instantiation return
 * NULL. Variable types an FMU does not have accept empty requests only.
 */
#include <stdlib.h>

#include "fmi3Functions.h"
#include "jxf_fmu.h"

typedef struct {
    jxf_instance core; /* first: the instance is also a jxf_instance */
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Instance;

#define INST(c) ((jxf_instance *)(c))
#define STATUS(result) ((result) == 0 ? fmi3OK : fmi3Error)

static void forward_log(void *context, int level, const char *message) {
    const Instance *inst = (const Instance *)context;
    fmi3Status status = level == JXF_LOG_ERROR ? fmi3Error
                        : level == JXF_LOG_WARNING ? fmi3Warning : fmi3OK;
    const char *category = level == JXF_LOG_ERROR ? "logStatusError"
                           : level == JXF_LOG_WARNING ? "logStatusWarning" : "logAll";
    if (inst->log_message != NULL) inst->log_message(inst->environment, status, category, message);
}

/* ---- common functions --------------------------------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    return STATUS(jxf_set_logging(INST(instance), "fmi3SetDebugLogging", loggingOn, nCategories,
                                  categories));
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance *inst = (Instance *)calloc(1, sizeof(Instance));
    (void)instanceName, (void)visible, (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables, (void)intermediateUpdate;
    if (inst == NULL) return NULL;
    inst->environment = instanceEnvironment;
    inst->log_message = logMessage;
    inst->core.log.emit = forward_log;
    inst->core.log.context = inst;
    inst->core.log.debug = loggingOn;
    if (eventModeUsed)
        jxf_logf(&inst->core.log, JXF_LOG_ERROR, "event mode is not supported (hasEventMode is "
                 "false)");
    else if (nRequiredIntermediateVariables > 0)
        jxf_logf(&inst->core.log, JXF_LOG_ERROR, "intermediate variables are not supported");
    else if (jxf_instance_create(&inst->core, resourcePath, instantiationToken) == 0)
        return inst;
    free(inst);
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    if (instance == NULL) return;
    jxf_instance_free(INST(instance));
    free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return STATUS(jxf_setup(INST(instance), "fmi3EnterInitializationMode", startTime) ||
                  jxf_enter_initialization(INST(instance), "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return STATUS(jxf_exit_initialization(INST(instance), "fmi3ExitInitializationMode"));
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    return STATUS(jxf_terminate(INST(instance), "fmi3Terminate"));
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    return STATUS(jxf_reset(INST(instance), "fmi3Reset"));
}

/* ---- variables ---------------------------------------------------------------------- */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    return STATUS(jxf_get_reals(INST(instance), "fmi3GetFloat64", valueReferences,
                                nValueReferences, values, nValues));
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    return STATUS(jxf_set_reals(INST(instance), "fmi3SetFloat64", valueReferences,
                                nValueReferences, values, nValues));
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    size_t i;
    int flag;
    if (!jxf_allowed(INST(instance), "fmi3GetBoolean", JXF_ANY_STATE)) return fmi3Error;
    if (nValues != nValueReferences)
        return STATUS(jxf_unsupported(INST(instance), "fmi3GetBoolean of arrays"));
    for (i = 0; i < nValueReferences; ++i) {
        if (jxf_model_get_bool(INST(instance)->model, valueReferences[i], &flag)) return fmi3Error;
        values[i] = flag != 0;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    size_t i;
    int apply;
    if (!jxf_allowed(INST(instance), "fmi3SetBoolean", JXF_LIVE)) return fmi3Error;
    if (nValues != nValueReferences)
        return STATUS(jxf_unsupported(INST(instance), "fmi3SetBoolean of arrays"));
    for (apply = 0; apply < 2; ++apply) /* check all, then store all */
        for (i = 0; i < nValueReferences; ++i)
            if (jxf_model_set_bool(INST(instance)->model, valueReferences[i], values[i], apply))
                return fmi3Error;
    return fmi3OK;
}

JXF_SIGNATURES_BEGIN

#define NO_VARIABLES(name, ...)                                                       \
    fmi3Status name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                    __VA_ARGS__) {                                                    \
        return STATUS(jxf_no_variables(INST(instance), #name, nvr));                  \
    }
#define NO_GET_SET(Type)                                                              \
    NO_VARIABLES(fmi3Get##Type, fmi3##Type values[], size_t nValues)                  \
    NO_VARIABLES(fmi3Set##Type, const fmi3##Type values[], size_t nValues)

NO_GET_SET(Float32)
NO_GET_SET(Int8)
NO_GET_SET(UInt8)
NO_GET_SET(Int16)
NO_GET_SET(UInt16)
NO_GET_SET(Int32)
NO_GET_SET(UInt32)
NO_GET_SET(Int64)
NO_GET_SET(UInt64)
NO_GET_SET(String)
NO_VARIABLES(fmi3GetBinary, size_t sizes[], fmi3Binary values[], size_t nValues)
NO_VARIABLES(fmi3SetBinary, const size_t sizes[], const fmi3Binary values[], size_t nValues)
NO_VARIABLES(fmi3GetClock, fmi3Clock values[])
NO_VARIABLES(fmi3SetClock, const fmi3Clock values[])

/* ---- co-simulation ------------------------------------------------------------------ */

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    return STATUS(jxf_get_output_rates(INST(instance), "fmi3GetOutputDerivatives", vr, nvr,
                                       orders, values, nValues));
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    if (jxf_do_step(INST(instance), "fmi3DoStep", currentCommunicationPoint,
                    communicationStepSize))
        return fmi3Error;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = jxf_model_time(INST(instance)->model);
    return fmi3OK;
}

/* ---- functions that do not apply ---------------------------------------------------- */

static fmi3Instance refuse_instantiation(fmi3InstanceEnvironment environment,
                                         fmi3LogMessageCallback log_message, const char *text) {
    if (log_message != NULL) log_message(environment, fmi3Error, "logStatusError", text);
    return NULL;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName,
                                          fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    return refuse_instantiation(instanceEnvironment, logMessage,
                                "this FMU supports co-simulation only (no model exchange)");
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    return refuse_instantiation(instanceEnvironment, logMessage,
                                "this FMU supports co-simulation only (no scheduled execution)");
}

#define UNSUPPORTED(name, why, ...)                                                   \
    fmi3Status name(fmi3Instance instance, __VA_ARGS__) {                             \
        return STATUS(jxf_unsupported(INST(instance), #name " (" why ")"));           \
    }
#define UNSUPPORTED0(name, why)                                                       \
    fmi3Status name(fmi3Instance instance) {                                          \
        return STATUS(jxf_unsupported(INST(instance), #name " (" why ")"));           \
    }
#define NO_EVENTS "hasEventMode is false"
#define NO_CLOCKS "no clocks"
#define ME "model exchange"
#define VRS const fmi3ValueReference vr[], size_t nvr

UNSUPPORTED0(fmi3EnterEventMode, NO_EVENTS)
UNSUPPORTED0(fmi3EnterStepMode, NO_EVENTS)
UNSUPPORTED0(fmi3EvaluateDiscreteStates, NO_EVENTS)
UNSUPPORTED(fmi3UpdateDiscreteStates, NO_EVENTS, fmi3Boolean *need_update,
            fmi3Boolean *terminate, fmi3Boolean *nominals_changed, fmi3Boolean *values_changed,
            fmi3Boolean *next_event_defined, fmi3Float64 *next_event_time)
UNSUPPORTED(fmi3GetNumberOfVariableDependencies, "not provided", fmi3ValueReference vr, size_t *n)
UNSUPPORTED(fmi3GetVariableDependencies, "not provided", fmi3ValueReference dependent,
            size_t element_dep[], fmi3ValueReference independents[], size_t element_ind[],
            fmi3DependencyKind kinds[], size_t n)
JXF_NO_FMU_STATE(fmi3, S, fmi3DeserializeFMUState)
UNSUPPORTED(fmi3GetDirectionalDerivative, "providesDirectionalDerivative is false",
            const fmi3ValueReference unknowns[], size_t n_unknowns,
            const fmi3ValueReference knowns[], size_t n_knowns, const fmi3Float64 seed[],
            size_t n_seed, fmi3Float64 sensitivity[], size_t n_sensitivity)
UNSUPPORTED(fmi3GetAdjointDerivative, "providesAdjointDerivatives is false",
            const fmi3ValueReference unknowns[], size_t n_unknowns,
            const fmi3ValueReference knowns[], size_t n_knowns, const fmi3Float64 seed[],
            size_t n_seed, fmi3Float64 sensitivity[], size_t n_sensitivity)
UNSUPPORTED0(fmi3EnterConfigurationMode, "no structural parameters")
UNSUPPORTED0(fmi3ExitConfigurationMode, "no structural parameters")
UNSUPPORTED(fmi3GetIntervalDecimal, NO_CLOCKS, VRS, fmi3Float64 intervals[],
            fmi3IntervalQualifier qualifiers[])
UNSUPPORTED(fmi3GetIntervalFraction, NO_CLOCKS, VRS, fmi3UInt64 counters[],
            fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
UNSUPPORTED(fmi3GetShiftDecimal, NO_CLOCKS, VRS, fmi3Float64 shifts[])
UNSUPPORTED(fmi3GetShiftFraction, NO_CLOCKS, VRS, fmi3UInt64 counters[],
            fmi3UInt64 resolutions[])
UNSUPPORTED(fmi3SetIntervalDecimal, NO_CLOCKS, VRS, const fmi3Float64 intervals[])
UNSUPPORTED(fmi3SetIntervalFraction, NO_CLOCKS, VRS, const fmi3UInt64 counters[],
            const fmi3UInt64 resolutions[])
UNSUPPORTED(fmi3SetShiftDecimal, NO_CLOCKS, VRS, const fmi3Float64 shifts[])
UNSUPPORTED(fmi3SetShiftFraction, NO_CLOCKS, VRS, const fmi3UInt64 counters[],
            const fmi3UInt64 resolutions[])
UNSUPPORTED0(fmi3EnterContinuousTimeMode, ME)
UNSUPPORTED(fmi3CompletedIntegratorStep, ME, fmi3Boolean no_set_state, fmi3Boolean *enter_event,
            fmi3Boolean *terminate)
UNSUPPORTED(fmi3SetTime, ME, fmi3Float64 time)
UNSUPPORTED(fmi3SetContinuousStates, ME, const fmi3Float64 x[], size_t nx)
UNSUPPORTED(fmi3GetContinuousStateDerivatives, ME, fmi3Float64 derivatives[], size_t nx)
UNSUPPORTED(fmi3GetEventIndicators, ME, fmi3Float64 indicators[], size_t ni)
UNSUPPORTED(fmi3GetContinuousStates, ME, fmi3Float64 x[], size_t nx)
UNSUPPORTED(fmi3GetNominalsOfContinuousStates, ME, fmi3Float64 nominals[], size_t nx)
UNSUPPORTED(fmi3GetNumberOfEventIndicators, ME, size_t *n)
UNSUPPORTED(fmi3GetNumberOfContinuousStates, ME, size_t *n)
UNSUPPORTED(fmi3ActivateModelPartition, "scheduled execution", fmi3ValueReference clock,
            fmi3Float64 activation_time)

JXF_SIGNATURES_END

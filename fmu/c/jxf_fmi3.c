/* FMI 3.0 co-simulation interface of the jaxflex FMU core (jxf_core.h).
 *
 * FMI 3.0 has no input derivatives: inputs ax, ay, az (m/s^2) are held over a communication
 * step. The embedded trajectory (use_embedded_trajectory) is replayed exactly, linear between
 * its samples. Besides the scalar outputs the FMU provides the displaced coordinates of all
 * points (K x 3 array, m) and the undeformed coordinates (calculated parameter, K x 3, m).
 * Every FMI 3.0 function is exported; those that do not apply (model exchange, scheduled
 * execution, clocks, FMU state, derivatives, other variable types) log and return fmi3Error.
 */
#include <math.h>
#include <stdlib.h>

#include "fmi3Functions.h"
#include "jxf_core.h"

typedef struct {
    jxf_model *model;
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log_message;
} Instance;

#define MODEL(c) ((c) != NULL ? ((Instance *)(c))->model : NULL)
#define STATUS(result) ((result) == 0 ? fmi3OK : fmi3Error)

static void forward_log(void *context, int level, const char *message) {
    const Instance *inst = (const Instance *)context;
    fmi3Status status = level == JXF_LOG_ERROR ? fmi3Error
                        : level == JXF_LOG_WARNING ? fmi3Warning : fmi3OK;
    const char *category = level == JXF_LOG_ERROR ? "logStatusError"
                           : level == JXF_LOG_WARNING ? "logStatusWarning" : "logAll";
    if (inst->log_message != NULL) inst->log_message(inst->environment, status, category, message);
}

static fmi3Status unsupported(fmi3Instance instance, const char *function) {
    jxf_unsupported(MODEL(instance), function);
    return fmi3Error;
}

/* ---- common functions --------------------------------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    return STATUS(jxf_set_logging(MODEL(instance), "fmi3SetDebugLogging", loggingOn, nCategories,
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
    if (eventModeUsed) {
        forward_log(inst, JXF_LOG_ERROR, "event mode is not supported (hasEventMode is false)");
    } else if (nRequiredIntermediateVariables > 0) {
        forward_log(inst, JXF_LOG_ERROR, "intermediate variables are not supported");
    } else {
        inst->model = jxf_create(resourcePath, instantiationToken, forward_log, inst, loggingOn);
    }
    if (inst->model == NULL) {
        free(inst);
        return NULL;
    }
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName,
                                          fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible;
    (void)loggingOn;
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
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible;
    (void)loggingOn, (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU supports co-simulation only (no scheduled execution)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Instance *inst = (Instance *)instance;
    if (inst == NULL) return;
    jxf_destroy(inst->model);
    free(inst);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    jxf_model *m = MODEL(instance);
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return STATUS(jxf_setup(m, "fmi3EnterInitializationMode", startTime) ||
                  jxf_enter_initialization(m, "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return STATUS(jxf_exit_initialization(MODEL(instance), "fmi3ExitInitializationMode"));
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    return STATUS(jxf_terminate(MODEL(instance), "fmi3Terminate"));
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    return STATUS(jxf_reset(MODEL(instance), "fmi3Reset"));
}

/* ---- Float64 and Boolean variables -------------------------------------------------- */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    jxf_model *m = MODEL(instance);
    size_t i, k = 0;
    if (!jxf_allowed(m, "fmi3GetFloat64", JXF_ANY_STATE)) return fmi3Error;
    for (i = 0; i < nValueReferences; ++i) {
        const fmi3ValueReference vr = valueReferences[i];
        const size_t size = jxf_real_size(vr);
        if (k + size > nValues) {
            jxf_log(m, JXF_LOG_ERROR, "fmi3GetFloat64: nValues = %lu is too small for "
                    "the requested variables", (unsigned long)nValues);
            return fmi3Error;
        }
        if (jxf_get_real(m, vr, values + k)) return fmi3Error;
        k += size;
    }
    if (k != nValues) {
        jxf_log(m, JXF_LOG_ERROR, "fmi3GetFloat64: nValues = %lu, but the variables "
                "hold %lu values", (unsigned long)nValues, (unsigned long)k);
        return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    jxf_model *m = MODEL(instance);
    size_t i;
    int apply;
    if (!jxf_allowed(m, "fmi3SetFloat64", JXF_LIVE)) return fmi3Error;
    if (nValues != nValueReferences) {
        jxf_log(m, JXF_LOG_ERROR, "fmi3SetFloat64: only scalar variables can be set "
                "(nValues %lu != nValueReferences %lu)", (unsigned long)nValues,
                (unsigned long)nValueReferences);
        return fmi3Error;
    }
    for (apply = 0; apply < 2; ++apply) /* check all, then store all */
        for (i = 0; i < nValueReferences; ++i)
            if (jxf_set_real(m, valueReferences[i], values[i], apply)) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    jxf_model *m = MODEL(instance);
    size_t i;
    int flag;
    if (!jxf_allowed(m, "fmi3GetBoolean", JXF_ANY_STATE)) return fmi3Error;
    if (nValues != nValueReferences) return unsupported(instance, "fmi3GetBoolean of arrays");
    for (i = 0; i < nValueReferences; ++i) {
        if (jxf_get_bool(m, valueReferences[i], &flag)) return fmi3Error;
        values[i] = flag != 0;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    jxf_model *m = MODEL(instance);
    size_t i;
    int apply;
    if (!jxf_allowed(m, "fmi3SetBoolean", JXF_LIVE)) return fmi3Error;
    if (nValues != nValueReferences) return unsupported(instance, "fmi3SetBoolean of arrays");
    for (apply = 0; apply < 2; ++apply)
        for (i = 0; i < nValueReferences; ++i)
            if (jxf_set_bool(m, valueReferences[i], values[i], apply)) return fmi3Error;
    return fmi3OK;
}

/* Variable types this FMU does not have: fine for an empty request, an error otherwise. */
static fmi3Status no_variables(fmi3Instance instance, const char *function, size_t n) {
    if (!jxf_allowed(MODEL(instance), function, JXF_ANY_STATE)) return fmi3Error;
    if (n == 0) return fmi3OK;
    jxf_log(MODEL(instance), JXF_LOG_ERROR, "%s: this FMU has no variables of this type",
            function);
    return fmi3Error;
}

#define JXF_NO_GETTER(Type)                                                                  \
    fmi3Status fmi3Get##Type(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             fmi3##Type values[], size_t nValues) {                          \
        (void)vr, (void)values, (void)nValues;                                               \
        return no_variables(instance, "fmi3Get" #Type, nvr);                                 \
    }
#define JXF_NO_SETTER(Type)                                                                  \
    fmi3Status fmi3Set##Type(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                             const fmi3##Type values[], size_t nValues) {                    \
        (void)vr, (void)values, (void)nValues;                                               \
        return no_variables(instance, "fmi3Set" #Type, nvr);                                 \
    }
#define JXF_NO_VARIABLES(Type) JXF_NO_GETTER(Type) JXF_NO_SETTER(Type)

JXF_NO_VARIABLES(Float32)
JXF_NO_VARIABLES(Int8)
JXF_NO_VARIABLES(UInt8)
JXF_NO_VARIABLES(Int16)
JXF_NO_VARIABLES(UInt16)
JXF_NO_VARIABLES(Int32)
JXF_NO_VARIABLES(UInt32)
JXF_NO_VARIABLES(Int64)
JXF_NO_VARIABLES(UInt64)
JXF_NO_VARIABLES(String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)vr, (void)valueSizes, (void)values, (void)nValues;
    return no_variables(instance, "fmi3GetBinary", nvr);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)vr, (void)valueSizes, (void)values, (void)nValues;
    return no_variables(instance, "fmi3SetBinary", nvr);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Clock values[]) {
    (void)vr, (void)values;
    return no_variables(instance, "fmi3GetClock", nvr);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Clock values[]) {
    (void)vr, (void)values;
    return no_variables(instance, "fmi3SetClock", nvr);
}

/* ---- co-simulation ------------------------------------------------------------------ */

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    jxf_model *m = MODEL(instance);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!jxf_allowed(m, "fmi3DoStep", JXF_STEP)) return fmi3Error;
    if (jxf_do_step(m, currentCommunicationPoint, communicationStepSize)) return fmi3Error;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = m->time;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterStepMode (hasEventMode is false)");
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterEventMode (hasEventMode is false)");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    (void)vr, (void)nvr, (void)orders, (void)values, (void)nValues;
    return unsupported(instance, "fmi3GetOutputDerivatives (maxOutputDerivativeOrder is 0)");
}

/* ---- functions that do not apply ---------------------------------------------------- */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    return unsupported(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents;
    (void)elementIndicesOfIndependents, (void)dependencyKinds, (void)nDependencies;
    return unsupported(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    (void)FMUState;
    return unsupported(instance, "fmi3GetFMUState (canGetAndSetFMUState is false)");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    (void)FMUState;
    return unsupported(instance, "fmi3SetFMUState (canGetAndSetFMUState is false)");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    (void)FMUState;
    return unsupported(instance, "fmi3FreeFMUState (canGetAndSetFMUState is false)");
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                      size_t *size) {
    (void)FMUState, (void)size;
    return unsupported(instance, "fmi3SerializedFMUStateSize (canSerializeFMUState is false)");
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    (void)FMUState, (void)serializedState, (void)size;
    return unsupported(instance, "fmi3SerializeFMUState (canSerializeFMUState is false)");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    (void)serializedState, (void)size, (void)FMUState;
    return unsupported(instance, "fmi3DeserializeFMUState (canSerializeFMUState is false)");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed;
    (void)sensitivity, (void)nSensitivity;
    return unsupported(instance, "fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed;
    (void)sensitivity, (void)nSensitivity;
    return unsupported(instance, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterConfigurationMode (no structural parameters)");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3ExitConfigurationMode (no structural parameters)");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[],
                                  size_t nvr, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)vr, (void)nvr, (void)intervals, (void)qualifiers;
    return unsupported(instance, "fmi3GetIntervalDecimal (no clocks)");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions, (void)qualifiers;
    return unsupported(instance, "fmi3GetIntervalFraction (no clocks)");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               fmi3Float64 shifts[]) {
    (void)vr, (void)nvr, (void)shifts;
    return unsupported(instance, "fmi3GetShiftDecimal (no clocks)");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    return unsupported(instance, "fmi3GetShiftFraction (no clocks)");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[],
                                  size_t nvr, const fmi3Float64 intervals[]) {
    (void)vr, (void)nvr, (void)intervals;
    return unsupported(instance, "fmi3SetIntervalDecimal (no clocks)");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    return unsupported(instance, "fmi3SetIntervalFraction (no clocks)");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[]) {
    (void)vr, (void)nvr, (void)shifts;
    return unsupported(instance, "fmi3SetShiftDecimal (no clocks)");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    return unsupported(instance, "fmi3SetShiftFraction (no clocks)");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return unsupported(instance, "fmi3EvaluateDiscreteStates (hasEventMode is false)");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    (void)discreteStatesNeedUpdate, (void)terminateSimulation;
    (void)nominalsOfContinuousStatesChanged, (void)valuesOfContinuousStatesChanged;
    (void)nextEventTimeDefined, (void)nextEventTime;
    return unsupported(instance, "fmi3UpdateDiscreteStates (hasEventMode is false)");
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterContinuousTimeMode (model exchange)");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    return unsupported(instance, "fmi3CompletedIntegratorStep (model exchange)");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    return unsupported(instance, "fmi3SetTime (model exchange)");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates, (void)nContinuousStates;
    return unsupported(instance, "fmi3SetContinuousStates (model exchange)");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    (void)derivatives, (void)nContinuousStates;
    return unsupported(instance, "fmi3GetContinuousStateDerivatives (model exchange)");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators) {
    (void)eventIndicators, (void)nEventIndicators;
    return unsupported(instance, "fmi3GetEventIndicators (model exchange)");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates, (void)nContinuousStates;
    return unsupported(instance, "fmi3GetContinuousStates (model exchange)");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    (void)nominals, (void)nContinuousStates;
    return unsupported(instance, "fmi3GetNominalsOfContinuousStates (model exchange)");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    (void)nEventIndicators;
    return unsupported(instance, "fmi3GetNumberOfEventIndicators (model exchange)");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    (void)nContinuousStates;
    return unsupported(instance, "fmi3GetNumberOfContinuousStates (model exchange)");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    return unsupported(instance, "fmi3ActivateModelPartition (scheduled execution)");
}

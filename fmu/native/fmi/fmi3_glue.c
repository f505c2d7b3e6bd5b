/* fmi3_glue.c - FMI 3.0 co-simulation functions over fg_instance (model agnostic).
 * Supported: Float64, Int32, Boolean, String variables; FMU state; co-simulation without event mode.
 * All other functions of fmi3Functions.h are defined and return fmi3Error with a logged message.
 * Compiled with -DFG_SCHEDULED_EXECUTION, it leaves instantiation, the end of initialization and the
 * clock functions to fmi3_se_glue.c and refuses co-simulation (instantiation and doStep). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fg_instance.h"

#define INST ((fg_instance *)instance)
#define UNSUPPORTED(name) return (fmi3Status)fg_unsupported(INST, #name)

static void emit3(fg_instance *inst, fg_status status, const char *category, const char *message)
{
    fmi3LogMessageCallback logger = (fmi3LogMessageCallback)inst->logger;
    logger((fmi3InstanceEnvironment)inst->env, (fmi3Status)status, category, message);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    if (instance == NULL) return fmi3Error;
    if (!fg_args_ok(INST, "fmi3SetDebugLogging", nCategories, categories, categories)) return fmi3Error;
    INST->logging_on = loggingOn ? 1 : 0;
    return fmi3OK;
}

/* logs through a temporary instance (the real one does not exist yet) */
static void refuse(fmi3String name, fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage,
                   const char *message, const char *detail)
{
    fg_instance tmp;
    if (logMessage == NULL) return;
    memset(&tmp, 0, sizeof tmp);
    tmp.name = (char *)(name != NULL ? name : "?");
    tmp.env = env;
    tmp.logger = (fg_generic_fn)logMessage;
    tmp.emit = emit3;
    fg_log(&tmp, FG_ERROR, NULL, "%s%s", message, detail);
}

#if !defined(FG_MODEL_EXCHANGE) && !defined(FG_SCHEDULED_EXECUTION) /* else fmi3_me_glue.c, or refused below */
fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    fg_instance *inst;
    (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables; (void)intermediateUpdate;
    if (instanceName == NULL || instanceName[0] == '\0') {
        refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateCoSimulation: missing instance name", "");
        return NULL;
    }
    if (instantiationToken == NULL || strcmp(instantiationToken, INSTANTIATION_TOKEN) != 0) {
        char msg[160];
        snprintf(msg, sizeof msg, "fmi3InstantiateCoSimulation: instantiation token %.64s does not match ",
                 instantiationToken != NULL ? instantiationToken : "(NULL)");
        refuse(instanceName, instanceEnvironment, logMessage, msg, INSTANTIATION_TOKEN " of this binary");
        return NULL;
    }
    if (eventModeUsed) {
        refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateCoSimulation: event mode ",
               "is not supported (hasEventMode=false)");
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0) {
        refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateCoSimulation: intermediate ",
               "variables are not supported");
        return NULL;
    }
    inst = fg_instance_new(instanceName, resourcePath, instanceEnvironment, (fg_generic_fn)logMessage, emit3,
                           loggingOn ? 1 : 0);
    if (inst == NULL) refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateCoSimulation: ",
                             "out of memory");
    if (inst != NULL && logMessage == NULL) inst->logger = NULL;
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateModelExchange: ",
           "model exchange is not supported");
    return NULL;
}
#endif

#ifdef FG_SCHEDULED_EXECUTION /* a Scheduled Execution binary: no co-simulation, no model exchange */
fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn; (void)eventModeUsed;
    (void)earlyReturnAllowed; (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateCoSimulation: ",
           "this FMU is Scheduled Execution only (<ScheduledExecution>): activate its clock");
    return NULL;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateModelExchange: ",
           "model exchange is not supported");
    return NULL;
}
#else
fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateScheduledExecution: ",
           "scheduled execution is not supported");
    return NULL;
}
#endif

void fmi3FreeInstance(fmi3Instance instance) { fg_instance_free(INST); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined; (void)tolerance;
    if (instance != NULL && INST->phase == FG_PHASE_INSTANTIATED) {
        INST->stop_time = stopTimeDefined ? stopTime : INFINITY;
    }
    return (fmi3Status)fg_enter_initialization(INST, "fmi3EnterInitializationMode", startTime);
}

#ifndef FG_SCHEDULED_EXECUTION /* fmi3_se_glue.c checks the model's period there too */
fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    return (fmi3Status)fg_exit_initialization(INST, "fmi3ExitInitializationMode");
}
#endif

#ifndef FG_MODEL_EXCHANGE
fmi3Status fmi3EnterEventMode(fmi3Instance instance) { UNSUPPORTED(fmi3EnterEventMode); }
#endif

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    if (!fg_allowed(INST, "fmi3Terminate", FG_PHASE_STEP | FG_PHASE_STEP_FAILED)) return fmi3Error;
    INST->phase = FG_PHASE_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (instance == NULL) return fmi3Error;
    fg_instance_reset(INST);
    return fmi3OK;
}

static int scalar_counts(fmi3Instance instance, const char *func, size_t nvr, size_t nValues)
{
    if (nvr != nValues) {
        fg_log(INST, FG_ERROR, NULL, "%s: %lu value references but %lu values (arrays are not supported)", func,
               (unsigned long)nvr, (unsigned long)nValues);
        return 0;
    }
    return 1;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues)
{
    if (instance == NULL || !scalar_counts(instance, "fmi3GetFloat64", nvr, nValues)) return fmi3Error;
    return (fmi3Status)fg_get_real(INST, "fmi3GetFloat64", vr, nvr, values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues)
{
    if (instance == NULL || !scalar_counts(instance, "fmi3SetFloat64", nvr, nValues)) return fmi3Error;
    return (fmi3Status)fg_set_real(INST, "fmi3SetFloat64", vr, nvr, values);
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues)
{
    if (instance == NULL || !scalar_counts(instance, "fmi3GetInt32", nvr, nValues)) return fmi3Error;
    return (fmi3Status)fg_get_integer(INST, "fmi3GetInt32", vr, nvr, values);
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues)
{
    if (instance == NULL || !scalar_counts(instance, "fmi3SetInt32", nvr, nValues)) return fmi3Error;
    return (fmi3Status)fg_set_integer(INST, "fmi3SetInt32", vr, nvr, values);
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[],
                          size_t nValues)
{
    size_t i;
    fmi3Status s = fmi3OK, si;
    if (instance == NULL || !scalar_counts(instance, "fmi3GetBoolean", nvr, nValues)) return fmi3Error;
    if (!fg_args_ok(INST, "fmi3GetBoolean", nvr, vr, values)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        int b = 0;
        si = (fmi3Status)fg_get_boolean1(INST, "fmi3GetBoolean", vr[i], &b);
        if (si > s) s = si;
        if (s >= fmi3Error) return s;
        values[i] = b ? true : false;
    }
    return s;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Boolean values[], size_t nValues)
{
    size_t i;
    fmi3Status s = fmi3OK, si;
    if (instance == NULL || !scalar_counts(instance, "fmi3SetBoolean", nvr, nValues)) return fmi3Error;
    if (!fg_args_ok(INST, "fmi3SetBoolean", nvr, vr, values)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        si = (fmi3Status)fg_set_boolean1(INST, "fmi3SetBoolean", vr[i], values[i] ? 1 : 0);
        if (si > s) s = si;
        if (s >= fmi3Error) return s;
    }
    return s;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3String values[],
                         size_t nValues)
{
    if (instance == NULL || !scalar_counts(instance, "fmi3GetString", nvr, nValues)) return fmi3Error;
    return (fmi3Status)fg_get_string(INST, "fmi3GetString", vr, nvr, values);
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const fmi3String values[], size_t nValues)
{
    if (instance == NULL || !scalar_counts(instance, "fmi3SetString", nvr, nValues)) return fmi3Error;
    return (fmi3Status)fg_set_string(INST, "fmi3SetString", vr, nvr, values);
}

/* the types this glue does not carry */
#define UNSUPPORTED_GET(NAME, CTYPE)                                                                 \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, CTYPE values[], \
                    size_t nValues)                                                                   \
    {                                                                                                 \
        (void)vr; (void)nvr; (void)values; (void)nValues;                                             \
        UNSUPPORTED(NAME);                                                                            \
    }
#define UNSUPPORTED_SET(NAME, CTYPE)                                                                        \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const CTYPE values[], \
                    size_t nValues)                                                                         \
    {                                                                                                       \
        (void)vr; (void)nvr; (void)values; (void)nValues;                                                   \
        UNSUPPORTED(NAME);                                                                                  \
    }
UNSUPPORTED_GET(fmi3GetFloat32, fmi3Float32)
UNSUPPORTED_GET(fmi3GetInt8, fmi3Int8)
UNSUPPORTED_GET(fmi3GetUInt8, fmi3UInt8)
UNSUPPORTED_GET(fmi3GetInt16, fmi3Int16)
UNSUPPORTED_GET(fmi3GetUInt16, fmi3UInt16)
UNSUPPORTED_GET(fmi3GetUInt32, fmi3UInt32)
UNSUPPORTED_GET(fmi3GetInt64, fmi3Int64)
UNSUPPORTED_GET(fmi3GetUInt64, fmi3UInt64)
UNSUPPORTED_SET(fmi3SetFloat32, fmi3Float32)
UNSUPPORTED_SET(fmi3SetInt8, fmi3Int8)
UNSUPPORTED_SET(fmi3SetUInt8, fmi3UInt8)
UNSUPPORTED_SET(fmi3SetInt16, fmi3Int16)
UNSUPPORTED_SET(fmi3SetUInt16, fmi3UInt16)
UNSUPPORTED_SET(fmi3SetUInt32, fmi3UInt32)
UNSUPPORTED_SET(fmi3SetInt64, fmi3Int64)
UNSUPPORTED_SET(fmi3SetUInt64, fmi3UInt64)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues)
{
    (void)vr; (void)nvr; (void)valueSizes; (void)values; (void)nValues;
    UNSUPPORTED(fmi3GetBinary);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues)
{
    (void)vr; (void)nvr; (void)valueSizes; (void)values; (void)nValues;
    UNSUPPORTED(fmi3SetBinary);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[])
{
    (void)vr; (void)nvr; (void)values;
    UNSUPPORTED(fmi3GetClock);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[])
{
    (void)vr; (void)nvr; (void)values;
    UNSUPPORTED(fmi3SetClock);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference; (void)nDependencies;
    UNSUPPORTED(fmi3GetNumberOfVariableDependencies);
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    UNSUPPORTED(fmi3GetVariableDependencies);
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    return (fmi3Status)fg_state_get(INST, "fmi3GetFMUState", FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    return (fmi3Status)fg_state_set(INST, "fmi3SetFMUState", FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    if (instance == NULL) return fmi3Error;
    return (fmi3Status)fg_state_free(INST, "fmi3FreeFMUState", (void **)FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    if (instance == NULL) return fmi3Error;
    return (fmi3Status)fg_state_serialized_size(INST, "fmi3SerializedFMUStateSize", FMUState, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size)
{
    return (fmi3Status)fg_state_serialize(INST, "fmi3SerializeFMUState", FMUState, serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    return (fmi3Status)fg_state_deserialize(INST, "fmi3DeserializeFMUState", serializedState, size, FMUState);
}

#define UNSUPPORTED_DERIVATIVE(NAME)                                                                          \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,             \
                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, \
                    fmi3Float64 sensitivity[], size_t nSensitivity)                                           \
    {                                                                                                         \
        (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;                \
        (void)sensitivity; (void)nSensitivity;                                                                \
        UNSUPPORTED(NAME);                                                                                    \
    }
UNSUPPORTED_DERIVATIVE(fmi3GetDirectionalDerivative)
UNSUPPORTED_DERIVATIVE(fmi3GetAdjointDerivative)

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) { UNSUPPORTED(fmi3EnterConfigurationMode); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) { UNSUPPORTED(fmi3ExitConfigurationMode); }

#ifndef FG_SCHEDULED_EXECUTION /* fmi3_se_glue.c */
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)vr; (void)nvr; (void)intervals; (void)qualifiers;
    UNSUPPORTED(fmi3GetIntervalDecimal);
}
#endif

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                   fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions; (void)qualifiers;
    UNSUPPORTED(fmi3GetIntervalFraction);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[])
{
    (void)vr; (void)nvr; (void)shifts;
    UNSUPPORTED(fmi3GetShiftDecimal);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    UNSUPPORTED(fmi3GetShiftFraction);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    (void)vr; (void)nvr; (void)intervals;
    UNSUPPORTED(fmi3SetIntervalDecimal);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    UNSUPPORTED(fmi3SetIntervalFraction);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[])
{
    (void)vr; (void)nvr; (void)shifts;
    UNSUPPORTED(fmi3SetShiftDecimal);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    UNSUPPORTED(fmi3SetShiftFraction);
}

#ifndef FG_MODEL_EXCHANGE /* the model-exchange functions of fmi3_me_glue.c */
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { UNSUPPORTED(fmi3EvaluateDiscreteStates); }

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    (void)discreteStatesNeedUpdate; (void)terminateSimulation; (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged; (void)nextEventTimeDefined; (void)nextEventTime;
    UNSUPPORTED(fmi3UpdateDiscreteStates);
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) { UNSUPPORTED(fmi3EnterContinuousTimeMode); }

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    UNSUPPORTED(fmi3CompletedIntegratorStep);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    UNSUPPORTED(fmi3SetTime);
}

#define UNSUPPORTED_ME_ARRAY(NAME, CONST)                                              \
    fmi3Status NAME(fmi3Instance instance, CONST fmi3Float64 values[], size_t n)       \
    {                                                                                  \
        (void)values; (void)n;                                                         \
        UNSUPPORTED(NAME);                                                             \
    }
UNSUPPORTED_ME_ARRAY(fmi3SetContinuousStates, const)
UNSUPPORTED_ME_ARRAY(fmi3GetContinuousStateDerivatives, )
UNSUPPORTED_ME_ARRAY(fmi3GetEventIndicators, )
UNSUPPORTED_ME_ARRAY(fmi3GetContinuousStates, )
UNSUPPORTED_ME_ARRAY(fmi3GetNominalsOfContinuousStates, )

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    (void)nEventIndicators;
    UNSUPPORTED(fmi3GetNumberOfEventIndicators);
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    (void)nContinuousStates;
    UNSUPPORTED(fmi3GetNumberOfContinuousStates);
}
#endif

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { UNSUPPORTED(fmi3EnterStepMode); }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues)
{
    (void)vr; (void)nvr; (void)orders; (void)values; (void)nValues;
    UNSUPPORTED(fmi3GetOutputDerivatives);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    fg_status s;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (instance == NULL) return fmi3Error;
#ifdef FG_SCHEDULED_EXECUTION
    (void)currentCommunicationPoint; (void)communicationStepSize; (void)eventHandlingNeeded;
    (void)terminateSimulation; (void)earlyReturn; (void)lastSuccessfulTime; (void)s;
    fg_log(INST, FG_ERROR, NULL, "fmi3DoStep: a Scheduled Execution FMU is not stepped: activate its clock "
           "(fmi3ActivateModelPartition)");
    return fmi3Error;
#else
    if (eventHandlingNeeded == NULL || terminateSimulation == NULL || earlyReturn == NULL ||
        lastSuccessfulTime == NULL) {
        fg_log(INST, FG_ERROR, NULL, "fmi3DoStep: NULL out-argument");
        return fmi3Error;
    }
    s = fg_do_step(INST, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    *eventHandlingNeeded = false;
    *terminateSimulation = false;
    *earlyReturn = false;
    *lastSuccessfulTime = INST->time;
    return (fmi3Status)s;
#endif
}

#ifndef FG_SCHEDULED_EXECUTION /* fmi3_se_glue.c */
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference; (void)activationTime;
    UNSUPPORTED(fmi3ActivateModelPartition);
}
#endif

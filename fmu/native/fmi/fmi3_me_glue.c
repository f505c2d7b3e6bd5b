/* fmi3_me_glue.c - the FMI 3.0 model-exchange functions over fg_instance and fg_me.c (model agnostic,
 * models without events).  Linked with fg_instance.c and fmi3_glue.c compiled with -DFG_MODEL_EXCHANGE,
 * which leaves out its stubs of these functions; a model-exchange binary refuses co-simulation. */
#include <stdio.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fg_me.h"

#define INST ((fg_instance *)instance)

static void emit3(fg_instance *inst, fg_status status, const char *category, const char *message)
{
    fmi3LogMessageCallback logger = (fmi3LogMessageCallback)inst->logger;
    logger((fmi3InstanceEnvironment)inst->env, (fmi3Status)status, category, message);
}

/* logs through a temporary instance (the real one does not exist yet) */
static void refuse(fmi3String name, fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage,
                   const char *message)
{
    fg_instance tmp;
    if (logMessage == NULL) return;
    memset(&tmp, 0, sizeof tmp);
    tmp.name = (char *)(name != NULL ? name : "?");
    tmp.env = env;
    tmp.logger = (fg_generic_fn)logMessage;
    tmp.emit = emit3;
    fg_log(&tmp, FG_ERROR, NULL, "%s", message);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    fg_instance *inst;
    char msg[256];
    (void)visible;
    if (instanceName == NULL || instanceName[0] == '\0') {
        refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateModelExchange: missing instance name");
        return NULL;
    }
    if (instantiationToken == NULL || strcmp(instantiationToken, INSTANTIATION_TOKEN) != 0) {
        snprintf(msg, sizeof msg, "fmi3InstantiateModelExchange: instantiation token %.64s does not match %s "
                 "of this binary", instantiationToken != NULL ? instantiationToken : "(NULL)", INSTANTIATION_TOKEN);
        refuse(instanceName, instanceEnvironment, logMessage, msg);
        return NULL;
    }
    inst = fg_instance_new(instanceName, resourcePath, instanceEnvironment, (fg_generic_fn)logMessage, emit3,
                           loggingOn ? 1 : 0);
    if (inst == NULL) refuse(instanceName, instanceEnvironment, logMessage, "fmi3InstantiateModelExchange: out of memory");
    if (inst != NULL && logMessage == NULL) inst->logger = NULL;
    return inst;
}

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
    refuse(instanceName, instanceEnvironment, logMessage,
           "fmi3InstantiateCoSimulation: " FG_MODEL_IDENTIFIER_STRING " supports model exchange only");
    return NULL;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    return (fmi3Status)fg_me_enter_event_mode(INST, "fmi3EnterEventMode");
}

/* no clocks, no discrete states: nothing to evaluate */
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    return fg_allowed(INST, "fmi3EvaluateDiscreteStates", FG_PHASE_STEP) ? fmi3OK : fmi3Error;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    fg_event_info info;
    fg_status s;
    int ok = discreteStatesNeedUpdate != NULL && terminateSimulation != NULL &&
             nominalsOfContinuousStatesChanged != NULL && valuesOfContinuousStatesChanged != NULL &&
             nextEventTimeDefined != NULL && nextEventTime != NULL;
    s = fg_me_update_discrete_states(INST, "fmi3UpdateDiscreteStates", ok ? &info : NULL);
    if (s > FG_WARNING) return (fmi3Status)s;
    *discreteStatesNeedUpdate = info.discrete_states_need_update != 0;
    *terminateSimulation = info.terminate_simulation != 0;
    *nominalsOfContinuousStatesChanged = info.nominals_changed != 0;
    *valuesOfContinuousStatesChanged = info.values_changed != 0;
    *nextEventTimeDefined = info.next_event_time_defined != 0;
    *nextEventTime = info.next_event_time;
    return (fmi3Status)s;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return (fmi3Status)fg_me_enter_continuous_time_mode(INST, "fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    int event = 0, terminate = 0;
    fg_status s;
    (void)noSetFMUStatePriorToCurrentPoint;
    s = fg_me_completed_integrator_step(INST, "fmi3CompletedIntegratorStep", enterEventMode != NULL ? &event : NULL,
                                        terminateSimulation != NULL ? &terminate : NULL);
    if (s > FG_WARNING) return (fmi3Status)s;
    *enterEventMode = event != 0;
    *terminateSimulation = terminate != 0;
    return (fmi3Status)s;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    return (fmi3Status)fg_me_set_time(INST, "fmi3SetTime", time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    return (fmi3Status)fg_me_set_states(INST, "fmi3SetContinuousStates", continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    return (fmi3Status)fg_me_get_derivatives(INST, "fmi3GetContinuousStateDerivatives", derivatives,
                                             nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    return (fmi3Status)fg_me_get_event_indicators(INST, "fmi3GetEventIndicators", eventIndicators,
                                                  nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    return (fmi3Status)fg_me_get_states(INST, "fmi3GetContinuousStates", continuousStates, nContinuousStates);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates)
{
    return (fmi3Status)fg_me_get_nominals(INST, "fmi3GetNominalsOfContinuousStates", nominals, nContinuousStates);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    if (!fg_allowed(INST, "fmi3GetNumberOfEventIndicators", FG_PHASE_ANY)) return fmi3Error;
    if (nEventIndicators == NULL) {
        fg_log(INST, FG_ERROR, NULL, "fmi3GetNumberOfEventIndicators: NULL argument");
        return fmi3Error;
    }
    *nEventIndicators = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    if (!fg_allowed(INST, "fmi3GetNumberOfContinuousStates", FG_PHASE_ANY)) return fmi3Error;
    if (nContinuousStates == NULL) {
        fg_log(INST, FG_ERROR, NULL, "fmi3GetNumberOfContinuousStates: NULL argument");
        return fmi3Error;
    }
    *nContinuousStates = FG_MODEL_N_STATES;
    return fmi3OK;
}

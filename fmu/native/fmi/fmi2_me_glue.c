/* fmi2_me_glue.c - the FMI 2.0 model-exchange functions over fg_instance and fg_me.c (model agnostic,
 * models without events).  Linked with fg_instance.c and fmi2_glue.c compiled with -DFG_MODEL_EXCHANGE
 * (instantiation, variables, FMU states and the life cycle are theirs). */
#include "fmi2Functions.h"
#include "fg_me.h"

#define INST ((fg_instance *)c)

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    return (fmi2Status)fg_me_enter_event_mode(INST, "fmi2EnterEventMode");
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    fg_event_info info;
    fg_status s = fg_me_update_discrete_states(INST, "fmi2NewDiscreteStates", eventInfo != NULL ? &info : NULL);
    if (s > FG_WARNING) return (fmi2Status)s;
    eventInfo->newDiscreteStatesNeeded = info.discrete_states_need_update ? fmi2True : fmi2False;
    eventInfo->terminateSimulation = info.terminate_simulation ? fmi2True : fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = info.nominals_changed ? fmi2True : fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = info.values_changed ? fmi2True : fmi2False;
    eventInfo->nextEventTimeDefined = info.next_event_time_defined ? fmi2True : fmi2False;
    eventInfo->nextEventTime = info.next_event_time;
    return (fmi2Status)s;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    return (fmi2Status)fg_me_enter_continuous_time_mode(INST, "fmi2EnterContinuousTimeMode");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    int event = 0, terminate = 0;
    fg_status s;
    (void)noSetFMUStatePriorToCurrentPoint;
    s = fg_me_completed_integrator_step(INST, "fmi2CompletedIntegratorStep", enterEventMode != NULL ? &event : NULL,
                                        terminateSimulation != NULL ? &terminate : NULL);
    if (s > FG_WARNING) return (fmi2Status)s;
    *enterEventMode = event ? fmi2True : fmi2False;
    *terminateSimulation = terminate ? fmi2True : fmi2False;
    return (fmi2Status)s;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    return (fmi2Status)fg_me_set_time(INST, "fmi2SetTime", time);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    return (fmi2Status)fg_me_set_states(INST, "fmi2SetContinuousStates", x, nx);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    return (fmi2Status)fg_me_get_derivatives(INST, "fmi2GetDerivatives", derivatives, nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    return (fmi2Status)fg_me_get_event_indicators(INST, "fmi2GetEventIndicators", eventIndicators, ni);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    return (fmi2Status)fg_me_get_states(INST, "fmi2GetContinuousStates", x, nx);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    return (fmi2Status)fg_me_get_nominals(INST, "fmi2GetNominalsOfContinuousStates", x_nominal, nx);
}

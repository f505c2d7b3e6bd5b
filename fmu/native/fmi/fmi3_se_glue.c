/* fmi3_se_glue.c - FMI 3.0 Scheduled Execution over fg_instance (model agnostic): one periodic input
 * clock of constant interval (FG_CLOCK_VR, FG_CLOCK_INTERVAL), whose model partition is the whole
 * model; an activation at t runs fg_model_do_step(t, FG_CLOCK_INTERVAL).  Linked with fg_instance.c,
 * fg_state.c and fmi3_glue.c compiled with -DFG_SCHEDULED_EXECUTION (which leaves these functions to
 * this file).  The model says its period (fg_model_clock.h).
 *
 * The state machine: instantiated, initialization mode, then clock activation mode (the glue's step
 * phase): inputs are set, the partition activated, outputs read, at each tick t0 + k interval (t0 the
 * start time; the first tick at t0, shiftDecimal 0).  An activation at any other time, or of another
 * clock, is an error and changes nothing; a model discard (a non-finite input) leaves getters,
 * terminate, reset, set-state and free, as a discarded co-simulation step does.  No output clocks, so
 * the clockUpdate callback is never called and no preemption lock is taken. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fg_instance.h"
#include "fg_model_clock.h"

#if !defined(FG_CLOCK_VR) || !defined(FG_CLOCK_INTERVAL)
#error "compile with -DFG_CLOCK_VR=<value reference> -DFG_CLOCK_INTERVAL=<interval in s>"
#endif

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

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    fg_instance *inst;
    char msg[256];
    (void)visible; (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption; /* no output clocks */
    if (instanceName == NULL || instanceName[0] == '\0') {
        refuse(instanceName, instanceEnvironment, logMessage,
               "fmi3InstantiateScheduledExecution: missing instance name");
        return NULL;
    }
    if (instantiationToken == NULL || strcmp(instantiationToken, INSTANTIATION_TOKEN) != 0) {
        snprintf(msg, sizeof msg, "fmi3InstantiateScheduledExecution: instantiation token %.64s does not match "
                 "%s of this binary", instantiationToken != NULL ? instantiationToken : "(NULL)",
                 INSTANTIATION_TOKEN);
        refuse(instanceName, instanceEnvironment, logMessage, msg);
        return NULL;
    }
    inst = fg_instance_new(instanceName, resourcePath, instanceEnvironment, (fg_generic_fn)logMessage, emit3,
                           loggingOn ? 1 : 0);
    if (inst == NULL) refuse(instanceName, instanceEnvironment, logMessage,
                             "fmi3InstantiateScheduledExecution: out of memory");
    if (inst != NULL && logMessage == NULL) inst->logger = NULL;
    return inst;
}

/* the initialization ends as in co-simulation, then the model's period must be the clock's interval */
fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    fg_status s = fg_exit_initialization(INST, "fmi3ExitInitializationMode");
    double period;
    if (s >= FG_DISCARD) return (fmi3Status)s;
    period = fg_model_clock_period(INST->data);
    if (period != (double)FG_CLOCK_INTERVAL) {
        fg_log(INST, FG_ERROR, NULL, "fmi3ExitInitializationMode: the sample period %.17g s differs from the "
               "constant interval %.17g s of the clock (valueReference %u, intervalDecimal in "
               "modelDescription.xml): a Scheduled Execution FMU keeps its declared period", period,
               (double)FG_CLOCK_INTERVAL, (unsigned)FG_CLOCK_VR);
        INST->phase = FG_PHASE_ERROR;
        return fmi3Error;
    }
    return (fmi3Status)s;
}

static int clock_ok(fg_instance *inst, const char *func, fmi3ValueReference vr)
{
    if (vr != (fmi3ValueReference)FG_CLOCK_VR) {
        fg_log(inst, FG_ERROR, NULL, "%s: value reference %u is not a clock (the clock is %u)", func, (unsigned)vr,
               (unsigned)FG_CLOCK_VR);
        return 0;
    }
    return 1;
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    const char *func = "fmi3ActivateModelPartition";
    double tol;
    fg_status s;
    if (!fg_allowed(INST, func, FG_PHASE_STEP)) return fmi3Error;
    if (!clock_ok(INST, func, clockReference)) return fmi3Error;
    tol = 1e-9 * (fabs(INST->time) > 1.0 ? fabs(INST->time) : 1.0); /* as a co-simulation step's time */
    if (!isfinite(activationTime) || fabs(activationTime - INST->time) > tol) {
        fg_log(INST, FG_ERROR, NULL, "%s: activation time %.17g s is not the clock's next tick %.17g s (a periodic "
               "clock of interval %.17g s from the start time)", func, activationTime, INST->time,
               (double)FG_CLOCK_INTERVAL);
        return fmi3Error;
    }
    s = fg_model_do_step(INST, INST->data, activationTime, (double)FG_CLOCK_INTERVAL);
    if (s <= FG_WARNING) {
        INST->time = activationTime + (double)FG_CLOCK_INTERVAL;
    } else if (s == FG_DISCARD) {
        INST->phase = FG_PHASE_STEP_FAILED;
    } else {
        INST->phase = FG_PHASE_ERROR;
        s = FG_ERROR;
    }
    return (fmi3Status)s;
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    size_t i;
    const char *func = "fmi3GetIntervalDecimal";
    if (!fg_allowed(INST, func, FG_PHASE_INIT | FG_PHASE_STEP | FG_PHASE_STEP_FAILED)) return fmi3Error;
    if (!fg_args_ok(INST, func, nvr, vr, intervals) || !fg_args_ok(INST, func, nvr, qualifiers, qualifiers)) {
        return fmi3Error;
    }
    for (i = 0; i < nvr; i++) {
        if (!clock_ok(INST, func, vr[i])) return fmi3Error;
    }
    for (i = 0; i < nvr; i++) {
        intervals[i] = (double)FG_CLOCK_INTERVAL;
        qualifiers[i] = fmi3IntervalUnchanged; /* constant: the modelDescription.xml's intervalDecimal */
    }
    return fmi3OK;
}

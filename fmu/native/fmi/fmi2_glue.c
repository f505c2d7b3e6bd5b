/* fmi2_glue.c - FMI 2.0 co-simulation functions over fg_instance (model agnostic) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fg_instance.h"

#define INST ((fg_instance *)c)
#ifdef FG_MODEL_EXCHANGE
#define FG_FMI2_TYPE fmi2ModelExchange
#else
#define FG_FMI2_TYPE fmi2CoSimulation
#endif

/* the message of the FMI 2 logger is a printf format (importers, fmpy's proxy among them, format it
 * with the variadic arguments): pass the already formatted text with every '%' doubled */
static void emit2(fg_instance *inst, fg_status status, const char *category, const char *message)
{
    fmi2CallbackLogger logger = (fmi2CallbackLogger)inst->logger;
    char buf[2048];
    size_t i = 0;
    for (; *message != '\0' && i + 2 < sizeof buf; message++) {
        if (*message == '%') buf[i++] = '%';
        buf[i++] = *message;
    }
    buf[i] = '\0';
    logger((fmi2ComponentEnvironment)inst->env, inst->name, (fmi2Status)status, category, buf);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)categories;
    if (c == NULL) return fmi2Error;
    if (!fg_args_ok(INST, "fmi2SetDebugLogging", nCategories, categories, categories)) return fmi2Error;
    INST->logging_on = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    fg_instance tmp;
    fg_instance *inst;
    (void)visible;
    if (functions == NULL || functions->logger == NULL) return NULL;
    /* a temporary instance that can only log, for the refusals below */
    memset(&tmp, 0, sizeof tmp);
    tmp.name = (char *)(instanceName != NULL ? instanceName : "?");
    tmp.env = functions->componentEnvironment;
    tmp.logger = (fg_generic_fn)functions->logger;
    tmp.emit = emit2;
    if (instanceName == NULL || instanceName[0] == '\0') {
        fg_log(&tmp, FG_ERROR, NULL, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != FG_FMI2_TYPE) { /* -DFG_MODEL_EXCHANGE: the model-exchange build (fmi2_me_glue.c) */
        fg_log(&tmp, FG_ERROR, NULL, "fmi2Instantiate: %s supports %s only", FG_MODEL_IDENTIFIER_STRING,
               FG_FMI2_TYPE == fmi2CoSimulation ? "co-simulation" : "model exchange");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, INSTANTIATION_TOKEN) != 0) {
        fg_log(&tmp, FG_ERROR, NULL, "fmi2Instantiate: GUID %s does not match %s of this binary",
               fmuGUID != NULL ? fmuGUID : "(NULL)", INSTANTIATION_TOKEN);
        return NULL;
    }
    inst = fg_instance_new(instanceName, fmuResourceLocation, functions->componentEnvironment,
                           (fg_generic_fn)functions->logger, emit2, loggingOn ? 1 : 0);
    if (inst == NULL) fg_log(&tmp, FG_ERROR, NULL, "fmi2Instantiate: out of memory");
    return inst;
}

void fmi2FreeInstance(fmi2Component c) { fg_instance_free(INST); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    if (!fg_allowed(INST, "fmi2SetupExperiment", FG_PHASE_INSTANTIATED)) return fmi2Error;
    INST->time = startTime;
    INST->stop_time = stopTimeDefined ? stopTime : INFINITY;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    if (c == NULL) return fmi2Error;
    return (fmi2Status)fg_enter_initialization(INST, "fmi2EnterInitializationMode", INST->time);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return (fmi2Status)fg_exit_initialization(INST, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    if (!fg_allowed(INST, "fmi2Terminate", FG_PHASE_STEP | FG_PHASE_STEP_FAILED)) return fmi2Error;
    INST->phase = FG_PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    if (c == NULL) return fmi2Error;
    fg_instance_reset(INST);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return (fmi2Status)fg_get_real(INST, "fmi2GetReal", vr, nvr, value);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    return (fmi2Status)fg_get_integer(INST, "fmi2GetInteger", vr, nvr, (int32_t *)value);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    size_t i;
    fmi2Status s = fmi2OK, si;
    if (c == NULL || !fg_args_ok(INST, "fmi2GetBoolean", nvr, vr, value)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        int b = 0;
        si = (fmi2Status)fg_get_boolean1(INST, "fmi2GetBoolean", vr[i], &b);
        if (si > s) s = si;
        if (s >= fmi2Error) return s;
        value[i] = b ? fmi2True : fmi2False;
    }
    return s;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    return (fmi2Status)fg_get_string(INST, "fmi2GetString", vr, nvr, value);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return (fmi2Status)fg_set_real(INST, "fmi2SetReal", vr, nvr, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    return (fmi2Status)fg_set_integer(INST, "fmi2SetInteger", vr, nvr, (const int32_t *)value);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    size_t i;
    fmi2Status s = fmi2OK, si;
    if (c == NULL || !fg_args_ok(INST, "fmi2SetBoolean", nvr, vr, value)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        si = (fmi2Status)fg_set_boolean1(INST, "fmi2SetBoolean", vr[i], value[i] != fmi2False);
        if (si > s) s = si;
        if (s >= fmi2Error) return s;
    }
    return s;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    return (fmi2Status)fg_set_string(INST, "fmi2SetString", vr, nvr, value);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    return (fmi2Status)fg_state_get(INST, "fmi2GetFMUstate", FMUstate);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    return (fmi2Status)fg_state_set(INST, "fmi2SetFMUstate", FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    if (c == NULL) return fmi2Error;
    if (FMUstate == NULL) return fmi2OK;
    fg_state_free(*FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    if (c == NULL) return fmi2Error;
    if (FMUstate == NULL || size == NULL) {
        fg_log(INST, FG_ERROR, NULL, "fmi2SerializedFMUstateSize: NULL argument");
        return fmi2Error;
    }
    *size = fg_state_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    return (fmi2Status)fg_state_serialize(INST, "fmi2SerializeFMUstate", FMUstate, (unsigned char *)serializedState,
                                          size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    return (fmi2Status)fg_state_deserialize(INST, "fmi2DeSerializeFMUstate", (const unsigned char *)serializedState,
                                            size, FMUstate);
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return (fmi2Status)fg_unsupported(INST, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return (fmi2Status)fg_unsupported(INST, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return (fmi2Status)fg_unsupported(INST, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)fg_do_step(INST, "fmi2DoStep", currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) { return (fmi2Status)fg_unsupported(INST, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s; (void)value;
    return (fmi2Status)fg_unsupported(INST, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    if (c == NULL) return fmi2Error;
    if (s == fmi2LastSuccessfulTime && value != NULL) {
        *value = INST->time;
        return fmi2OK;
    }
    return (fmi2Status)fg_unsupported(INST, "fmi2GetRealStatus (other than fmi2LastSuccessfulTime)");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s; (void)value;
    return (fmi2Status)fg_unsupported(INST, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    if (c == NULL) return fmi2Error;
    if (s == fmi2Terminated && value != NULL) {
        *value = fmi2False;
        return fmi2OK;
    }
    return (fmi2Status)fg_unsupported(INST, "fmi2GetBooleanStatus (other than fmi2Terminated)");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)s; (void)value;
    return (fmi2Status)fg_unsupported(INST, "fmi2GetStringStatus");
}

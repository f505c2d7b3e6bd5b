/* fg_me.c - see fg_me.h */
#include "fg_me.h"

#include <math.h>

#define AFTER_INIT (FG_PHASE_STEP | FG_PHASE_TERMINATED)

/* 1 if inst is in step phase and in the wanted sub-mode (1 continuous-time, 0 event), else a message */
static int in_mode(fg_instance *inst, const char *func, int continuous)
{
    if (!fg_allowed(inst, func, FG_PHASE_STEP)) return 0;
    if (inst->me_continuous == continuous) return 1;
    fg_log(inst, FG_ERROR, NULL, "%s: only allowed in %s mode, the FMU is in %s mode", func,
           continuous ? "continuous-time" : "event", inst->me_continuous ? "continuous-time" : "event");
    return 0;
}

static int n_ok(fg_instance *inst, const char *func, size_t n, size_t expected, const void *a)
{
    if (n != expected) {
        fg_log(inst, FG_ERROR, NULL, "%s: %lu values, the model has %lu", func, (unsigned long)n,
               (unsigned long)expected);
        return 0;
    }
    return fg_args_ok(inst, func, n, a, a);
}

/* from continuous-time mode; in event mode already it changes nothing (as the Reference-FMUs allow it) */
fg_status fg_me_enter_event_mode(fg_instance *inst, const char *func)
{
    if (!fg_allowed(inst, func, FG_PHASE_STEP)) return FG_ERROR;
    inst->me_continuous = 0;
    return FG_OK;
}

fg_status fg_me_update_discrete_states(fg_instance *inst, const char *func, fg_event_info *info)
{
    if (!in_mode(inst, func, 0)) return FG_ERROR;
    if (info == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL argument", func);
        return FG_ERROR;
    }
    info->discrete_states_need_update = 0;
    info->terminate_simulation = 0;
    info->nominals_changed = 0;
    info->values_changed = 0;
    info->next_event_time_defined = 0;
    info->next_event_time = 0.0;
    return FG_OK;
}

fg_status fg_me_enter_continuous_time_mode(fg_instance *inst, const char *func)
{
    if (!in_mode(inst, func, 0)) return FG_ERROR;
    inst->me_continuous = 1;
    return FG_OK;
}

fg_status fg_me_completed_integrator_step(fg_instance *inst, const char *func, int *enter_event_mode,
                                          int *terminate_simulation)
{
    if (!in_mode(inst, func, 1)) return FG_ERROR;
    if (enter_event_mode == NULL || terminate_simulation == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL argument", func);
        return FG_ERROR;
    }
    *enter_event_mode = 0;
    *terminate_simulation = 0;
    return FG_OK;
}

fg_status fg_me_set_time(fg_instance *inst, const char *func, double t)
{
    fg_status s;
    if (!fg_allowed(inst, func, FG_PHASE_STEP)) return FG_ERROR;
    if (!isfinite(t)) {
        fg_log(inst, FG_ERROR, NULL, "%s: time %g is not finite", func, t);
        return FG_ERROR;
    }
    s = fg_model_set_time(inst, inst->data, t);
    if (s <= FG_WARNING) inst->time = t;
    return s;
}

fg_status fg_me_set_states(fg_instance *inst, const char *func, const double x[], size_t n)
{
    if (!in_mode(inst, func, 1) || !n_ok(inst, func, n, FG_MODEL_N_STATES, x)) return FG_ERROR;
    return fg_model_set_states(inst, inst->data, x);
}

fg_status fg_me_get_states(fg_instance *inst, const char *func, double x[], size_t n)
{
    if (!fg_allowed(inst, func, FG_PHASE_INIT | AFTER_INIT) || !n_ok(inst, func, n, FG_MODEL_N_STATES, x))
        return FG_ERROR;
    return fg_model_get_states(inst, inst->data, x);
}

fg_status fg_me_get_derivatives(fg_instance *inst, const char *func, double dx[], size_t n)
{
    if (!fg_allowed(inst, func, FG_PHASE_INIT | AFTER_INIT) || !n_ok(inst, func, n, FG_MODEL_N_STATES, dx))
        return FG_ERROR;
    return fg_model_get_derivatives(inst, inst->data, dx);
}

fg_status fg_me_get_nominals(fg_instance *inst, const char *func, double nominal[], size_t n)
{
    if (!fg_allowed(inst, func, FG_PHASE_INSTANTIATED | FG_PHASE_INIT | AFTER_INIT) ||
        !n_ok(inst, func, n, FG_MODEL_N_STATES, nominal))
        return FG_ERROR;
    return fg_model_get_nominals(inst, inst->data, nominal);
}

fg_status fg_me_get_event_indicators(fg_instance *inst, const char *func, double z[], size_t n)
{
    if (!fg_allowed(inst, func, FG_PHASE_INIT | AFTER_INIT) || !n_ok(inst, func, n, 0, z)) return FG_ERROR;
    return FG_OK;
}

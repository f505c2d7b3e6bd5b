/* fg_me.h - the model-exchange part of the glue shared by fmi2_me_glue.c and fmi3_me_glue.c (fg_me.c):
 * the phase checks of model exchange (event mode / continuous-time mode inside FG_PHASE_STEP, the
 * flag me_continuous of fg_instance) and the calls of the model's functions of fg_model_me.h.  For
 * models without events (see fg_model_me.h).  Every function logs why it refuses a call. */
#ifndef FG_ME_H
#define FG_ME_H

#include "fg_instance.h"
#include "fg_model_me.h"

/* what the event update reports for a model without events: nothing changed, no next time event */
typedef struct {
    int discrete_states_need_update, terminate_simulation, nominals_changed, values_changed,
        next_event_time_defined;
    double next_event_time;
} fg_event_info;

fg_status fg_me_enter_event_mode(fg_instance *inst, const char *func);
fg_status fg_me_update_discrete_states(fg_instance *inst, const char *func, fg_event_info *info);
fg_status fg_me_enter_continuous_time_mode(fg_instance *inst, const char *func);
fg_status fg_me_completed_integrator_step(fg_instance *inst, const char *func, int *enter_event_mode,
                                          int *terminate_simulation);
fg_status fg_me_set_time(fg_instance *inst, const char *func, double t);
fg_status fg_me_set_states(fg_instance *inst, const char *func, const double x[], size_t n);
fg_status fg_me_get_states(fg_instance *inst, const char *func, double x[], size_t n);
fg_status fg_me_get_derivatives(fg_instance *inst, const char *func, double dx[], size_t n);
fg_status fg_me_get_nominals(fg_instance *inst, const char *func, double nominal[], size_t n);
fg_status fg_me_get_event_indicators(fg_instance *inst, const char *func, double z[], size_t n);

#endif

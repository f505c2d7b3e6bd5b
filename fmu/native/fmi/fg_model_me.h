/* fg_model_me.h - the few extra functions a model implements to be built as a model-exchange FMU
 * (fmi2_me_glue.c, fmi3_me_glue.c), besides everything of fg_model.h.
 *
 * The model-exchange glue is model agnostic like the co-simulation one and reuses it: instance life,
 * variables, logging and FMU states are fg_instance.h's; fmi2_glue.c / fmi3_glue.c are compiled with
 * -DFG_MODEL_EXCHANGE, which makes them instantiate for model exchange and leaves the model-exchange
 * functions to the *_me_glue.c files.  It supports models WITHOUT events: no event indicators, no
 * time events, no discrete states; the event-mode calls a tool makes anyway (enterEventMode,
 * newDiscreteStates / updateDiscreteStates, enterContinuousTimeMode, completedIntegratorStep) are
 * accepted in the phases the standards allow them and report "nothing happened".
 *
 * The glue checks the phase (and, by the flag me_continuous of the instance, event mode or
 * continuous-time mode), NULL arrays and the number of states before it calls these; the model sees
 * exactly FG_MODEL_N_STATES values.  The continuous states are the model's to keep in its data
 * (so an FMU state saves them).  fg_model_do_step is never reached through a model-exchange
 * instance of a well-behaved host; a model-exchange model should refuse it with a message.
 */
#ifndef FG_MODEL_ME_H
#define FG_MODEL_ME_H

#include "fg_model.h"

#ifdef __cplusplus
extern "C" {
#endif

extern const size_t FG_MODEL_N_STATES; /* number of continuous states (> 0) */

/* the continuous states x[0 .. FG_MODEL_N_STATES-1]; in initialization mode the initial states of the
 * current parameters (the model may compute them on demand) */
fg_status fg_model_get_states(fg_instance *inst, void *data, double x[]);
/* new continuous states (continuous-time mode); the outputs follow them.  FG_DISCARD with a
 * message for a non-finite value (the states are then left unchanged). */
fg_status fg_model_set_states(fg_instance *inst, void *data, const double x[]);
/* the derivatives of the states at the current time, states and inputs; FG_DISCARD with a message
 * when they cannot be evaluated there (non-finite input or state, a failed solve) */
fg_status fg_model_get_derivatives(fg_instance *inst, void *data, double dx[]);
/* nominal magnitudes of the states (constant; any phase after instantiation) */
fg_status fg_model_get_nominals(fg_instance *inst, const void *data, double nominal[]);
/* the independent variable set by the importer (event or continuous-time mode); finite */
fg_status fg_model_set_time(fg_instance *inst, void *data, double t);

#ifdef __cplusplus
}
#endif
#endif

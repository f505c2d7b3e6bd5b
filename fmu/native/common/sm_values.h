/* The value store's accessors and small helpers shared by every native model (plant, controller,
 * ScenarioSignals): sm_values.c.  The store itself (sm_values: one slot per value reference) and the
 * variable table are the model's generated sm_vars.h / sm_vars.c (orchestration/packaging/native/tables.py);
 * the model's data struct starts with it.  The get/set functions of fg_model.h are defined in
 * sm_values.c once for every model (the glue has checked type, causality and phase before a call). */
#ifndef SM_VALUES_H
#define SM_VALUES_H

#include <stddef.h>

#include "fg_model.h"

/* The file named by the parameter name, resolved in place in path (a buffer of cap bytes): as given
 * if it exists (or is empty, or there are no resources), else the FMU's resources directory + its
 * base name.  FG_ERROR, with a message naming the parameter, when the resolved path does not fit. */
fg_status sm_resolve_file(fg_instance *inst, const char *name, char *path, size_t cap);

#ifdef FG_MODEL_EXCHANGE
/* A model-exchange model's outputs may depend on its inputs at the same instant (direct feedthrough):
 * every set of a Real input calls this (the model implements it) to bring them up to date. */
void sm_model_input_changed(fg_instance *inst, void *data);
#endif

#endif

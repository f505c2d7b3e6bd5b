/* Get/set of a native model's values by value reference, shared by the plant and the controller
 * models: every value lives in the generated sm_values store (sm_vars.h), so the accessors are the
 * same for both (the glue has checked the type, causality and phase before any call).  Include
 * once, in the model's .c file, after sm_vars.h; the model's data struct starts with sm_values. */
#ifndef SM_VALUES_ACCESS_H
#define SM_VALUES_ACCESS_H

#include <stdio.h>
#include <string.h>

#include "sm_model.h"

sm_status sm_model_get_real(sm_instance *inst, const void *data, uint32_t vr, double *value)
{
    (void)inst;
    *value = ((const sm_values *)data)->r[vr];
    return SM_OK;
}

sm_status sm_model_set_real(sm_instance *inst, void *data, uint32_t vr, double value)
{
    (void)inst;
    ((sm_values *)data)->r[vr] = value;
    return SM_OK;
}

sm_status sm_model_get_integer(sm_instance *inst, const void *data, uint32_t vr, int32_t *value)
{
    (void)inst;
    *value = ((const sm_values *)data)->i[vr];
    return SM_OK;
}

sm_status sm_model_set_integer(sm_instance *inst, void *data, uint32_t vr, int32_t value)
{
    (void)inst;
    ((sm_values *)data)->i[vr] = value;
    return SM_OK;
}

sm_status sm_model_get_boolean(sm_instance *inst, const void *data, uint32_t vr, int *value)
{
    (void)inst;
    *value = ((const sm_values *)data)->b[vr];
    return SM_OK;
}

sm_status sm_model_set_boolean(sm_instance *inst, void *data, uint32_t vr, int value)
{
    (void)inst;
    ((sm_values *)data)->b[vr] = value ? 1 : 0;
    return SM_OK;
}

sm_status sm_model_get_string(sm_instance *inst, const void *data, uint32_t vr, const char **value)
{
    (void)inst;
    *value = ((const sm_values *)data)->s[SM_STRING_SLOT[vr]];
    return SM_OK;
}

sm_status sm_model_set_string(sm_instance *inst, void *data, uint32_t vr, const char *value)
{
    sm_values *v = (sm_values *)data;
    if (strlen(value) >= SM_VAR_STRING_MAX) {
        sm_log(inst, SM_ERROR, NULL, "%s: a string of %u bytes is longer than %d", SM_MODEL_VARIABLES[vr].name,
               (unsigned)strlen(value), SM_VAR_STRING_MAX - 1);
        return SM_ERROR;
    }
    strcpy(v->s[SM_STRING_SLOT[vr]], value);
    return SM_OK;
}

/* A table file: as given if it exists, else in the FMU's resources (the file's base name). */
static void sm_resolve_file(sm_instance *inst, const char *path, char *out, size_t len)
{
    const char *res = sm_resource_path(inst), *base = strrchr(path, '/');
    FILE *f;
    (void)snprintf(out, len, "%s", path);
    if (path[0] == '\0' || res == NULL) {
        return;
    }
    f = fopen(path, "rb");
    if (f != NULL) {
        fclose(f);
        return;
    }
    (void)snprintf(out, len, "%s%s", res, base ? base + 1 : path);
}

#endif

/* The typed get/set of sm_model.h on the generated value store (sm_values of sm_vars.h), the same
 * file for every native model (see sm_values.h).  Compiled once per model, with its sm_vars.h. */
#include <stdio.h>
#include <string.h>

#include "sm_values.h"
#include "sm_vars.h"

/* the glue checks every value reference against SM_MODEL_VARIABLES before a call: this is a second,
 * cheap guard against an out-of-range slot (vr of the given type, SM_N_VARS: time, a Real) */
static int bad_vr(sm_instance *inst, uint32_t vr, sm_type type)
{
    if (vr < SM_N_VARS ? SM_MODEL_VARIABLES[vr].type == type : (vr == SM_VR_time && type == SM_REAL)) {
        return 0;
    }
    sm_log(inst, SM_ERROR, NULL, "value reference %lu is not a variable of this type", (unsigned long)vr);
    return 1;
}

sm_status sm_model_get_real(sm_instance *inst, const void *data, uint32_t vr, double *value)
{
    if (bad_vr(inst, vr, SM_REAL)) {
        return SM_ERROR;
    }
    *value = ((const sm_values *)data)->r[vr];
    return SM_OK;
}

sm_status sm_model_set_real(sm_instance *inst, void *data, uint32_t vr, double value)
{
    if (bad_vr(inst, vr, SM_REAL)) {
        return SM_ERROR;
    }
    ((sm_values *)data)->r[vr] = value;
    return SM_OK;
}

sm_status sm_model_get_integer(sm_instance *inst, const void *data, uint32_t vr, int32_t *value)
{
    if (bad_vr(inst, vr, SM_INTEGER)) {
        return SM_ERROR;
    }
    *value = ((const sm_values *)data)->i[vr];
    return SM_OK;
}

sm_status sm_model_set_integer(sm_instance *inst, void *data, uint32_t vr, int32_t value)
{
    if (bad_vr(inst, vr, SM_INTEGER)) {
        return SM_ERROR;
    }
    ((sm_values *)data)->i[vr] = value;
    return SM_OK;
}

sm_status sm_model_get_boolean(sm_instance *inst, const void *data, uint32_t vr, int *value)
{
    if (bad_vr(inst, vr, SM_BOOLEAN)) {
        return SM_ERROR;
    }
    *value = ((const sm_values *)data)->b[vr];
    return SM_OK;
}

sm_status sm_model_set_boolean(sm_instance *inst, void *data, uint32_t vr, int value)
{
    if (bad_vr(inst, vr, SM_BOOLEAN)) {
        return SM_ERROR;
    }
    ((sm_values *)data)->b[vr] = value ? 1 : 0;
    return SM_OK;
}

sm_status sm_model_get_string(sm_instance *inst, const void *data, uint32_t vr, const char **value)
{
    if (bad_vr(inst, vr, SM_STRING)) {
        return SM_ERROR;
    }
    *value = ((const sm_values *)data)->s[SM_STRING_SLOT[vr]];
    return SM_OK;
}

sm_status sm_model_set_string(sm_instance *inst, void *data, uint32_t vr, const char *value)
{
    sm_values *v = (sm_values *)data;
    if (bad_vr(inst, vr, SM_STRING)) {
        return SM_ERROR;
    }
    if (value == NULL) {
        sm_log(inst, SM_ERROR, NULL, "%s: NULL string", SM_MODEL_VARIABLES[vr].name);
        return SM_ERROR;
    }
    if (strlen(value) >= SM_VAR_STRING_MAX) {
        sm_log(inst, SM_ERROR, NULL, "%s: a string of %u bytes is longer than %d", SM_MODEL_VARIABLES[vr].name,
               (unsigned)strlen(value), SM_VAR_STRING_MAX - 1);
        return SM_ERROR;
    }
    memset(v->s[SM_STRING_SLOT[vr]], 0, SM_VAR_STRING_MAX);
    strcpy(v->s[SM_STRING_SLOT[vr]], value);
    return SM_OK;
}

void sm_resolve_file(sm_instance *inst, const char *path, char *out, size_t len)
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

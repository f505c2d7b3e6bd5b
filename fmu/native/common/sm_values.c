/* The typed get/set of fg_model.h on the generated value store (sm_values of sm_vars.h), the same
 * file for every native model (see sm_values.h).  Compiled once per model, with its sm_vars.h. */
#include <stdio.h>
#include <string.h>

#include "sm_values.h"
#include "sm_vars.h"

/* the glue checks every value reference against FG_MODEL_VARIABLES before a call: this is a second,
 * cheap guard against an out-of-range slot (the generated table lists value reference k at k) */
static int bad_vr(fg_instance *inst, uint32_t vr, fg_type type)
{
    if (vr < SM_N_VALUES && FG_MODEL_VARIABLES[vr].vr == vr && FG_MODEL_VARIABLES[vr].type == type) {
        return 0;
    }
    fg_log(inst, FG_ERROR, NULL, "value reference %lu is not a variable of this type", (unsigned long)vr);
    return 1;
}

fg_status fg_model_get_real(fg_instance *inst, const void *data, uint32_t vr, double *value)
{
    if (bad_vr(inst, vr, FG_REAL)) {
        return FG_ERROR;
    }
    *value = ((const sm_values *)data)->r[vr];
    return FG_OK;
}

fg_status fg_model_set_real(fg_instance *inst, void *data, uint32_t vr, double value)
{
    if (bad_vr(inst, vr, FG_REAL)) {
        return FG_ERROR;
    }
    ((sm_values *)data)->r[vr] = value;
#ifdef FG_MODEL_EXCHANGE
    if (FG_MODEL_VARIABLES[vr].kind == FG_INPUT) sm_model_input_changed(inst, data);
#endif
    return FG_OK;
}

fg_status fg_model_get_integer(fg_instance *inst, const void *data, uint32_t vr, int32_t *value)
{
    if (bad_vr(inst, vr, FG_INTEGER)) {
        return FG_ERROR;
    }
    *value = ((const sm_values *)data)->i[vr];
    return FG_OK;
}

fg_status fg_model_set_integer(fg_instance *inst, void *data, uint32_t vr, int32_t value)
{
    if (bad_vr(inst, vr, FG_INTEGER)) {
        return FG_ERROR;
    }
    ((sm_values *)data)->i[vr] = value;
    return FG_OK;
}

fg_status fg_model_get_boolean(fg_instance *inst, const void *data, uint32_t vr, int *value)
{
    if (bad_vr(inst, vr, FG_BOOLEAN)) {
        return FG_ERROR;
    }
    *value = ((const sm_values *)data)->b[vr];
    return FG_OK;
}

fg_status fg_model_set_boolean(fg_instance *inst, void *data, uint32_t vr, int value)
{
    if (bad_vr(inst, vr, FG_BOOLEAN)) {
        return FG_ERROR;
    }
    ((sm_values *)data)->b[vr] = value ? 1 : 0;
    return FG_OK;
}

fg_status fg_model_get_string(fg_instance *inst, const void *data, uint32_t vr, const char **value)
{
    if (bad_vr(inst, vr, FG_STRING)) {
        return FG_ERROR;
    }
    *value = ((const sm_values *)data)->s[SM_STRING_SLOT[vr]];
    return FG_OK;
}

fg_status fg_model_set_string(fg_instance *inst, void *data, uint32_t vr, const char *value)
{
    sm_values *v = (sm_values *)data;
    if (bad_vr(inst, vr, FG_STRING)) {
        return FG_ERROR;
    }
    if (value == NULL) {
        fg_log(inst, FG_ERROR, NULL, "%s: NULL string", FG_MODEL_VARIABLES[vr].name);
        return FG_ERROR;
    }
    if (strlen(value) >= SM_VAR_STRING_MAX) {
        fg_log(inst, FG_ERROR, NULL, "%s: a string of %u bytes is longer than %d", FG_MODEL_VARIABLES[vr].name,
               (unsigned)strlen(value), SM_VAR_STRING_MAX - 1);
        return FG_ERROR;
    }
    memset(v->s[SM_STRING_SLOT[vr]], 0, SM_VAR_STRING_MAX);
    strcpy(v->s[SM_STRING_SLOT[vr]], value);
    return FG_OK;
}

fg_status sm_resolve_file(fg_instance *inst, const char *name, char *path, size_t cap)
{
    const char *res = fg_resource_path(inst), *base = strrchr(path, '/');
    char out[SM_VAR_STRING_MAX + 512];
    FILE *f;
    if (path[0] == '\0' || res == NULL) {
        return FG_OK;
    }
    f = fopen(path, "rb");
    if (f != NULL) {
        fclose(f);
        return FG_OK;
    }
    (void)snprintf(out, sizeof out, "%s%s", res, base ? base + 1 : path);
    if (strlen(out) >= cap) {
        fg_log(inst, FG_ERROR, "logStatusError", "%s: the path in the FMU's resources is %u bytes long, "
               "more than %d: %.200s", name, (unsigned)strlen(out), (int)cap - 1, out);
        return FG_ERROR;
    }
    strcpy(path, out);
    return FG_OK;
}

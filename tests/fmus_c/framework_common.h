/*
 * What the FMI 1.0, 2.0 and 3.0 test frameworks share: the call-state check, loading start values and
 * refreshing calculated values.  Included by each framework after it has defined its Instance (with a
 * ModelData `d` and an FwState `state` that has ST_FATAL) and the LOGE macro.  check() returns an FMI status
 * number (OK 0, Error 3, Fatal 4: the same in FMI 1.0, 2.0 and 3.0), which each framework compares with its
 * own fmiXOK.
 */
#ifndef FRAMEWORK_COMMON_H
#define FRAMEWORK_COMMON_H

#include <stdlib.h>
#include <string.h>

/* `allowed` is a bitmask of (1 << FwState) */
#define MASK(s) (1u << (s))
#define ANY_STATE 0xFFFFu

static int check(Instance *inst, const char *fname, unsigned allowed)
{
    if (inst == NULL) return M_ERROR;
    if (inst->state == ST_FATAL) {
        LOGE(inst, "%s: the FMU is in a fatal state", fname);
        return M_FATAL;
    }
    if (!(allowed & MASK(inst->state))) {
        LOGE(inst, "%s: illegal call sequence: not allowed in the current state (%d)", fname, (int)inst->state);
        return M_ERROR;
    }
    return M_OK;
}

static void load_start_values(Instance *inst)
{
    ModelData *d = &inst->d;
    int k;
    for (k = 0; k < NVARS; k++) {
        d->r[k] = START_REAL[k];
        d->i[k] = START_INT[k];
        d->b[k] = START_BOOL[k];
        free(d->s[k]);
        d->s[k] = NULL;
        if (VAR_TYPE[k] == T_STRING) {
            const char *s0 = START_STRING[k] ? START_STRING[k] : "";
            d->s[k] = (char *)malloc(strlen(s0) + 1);
            if (d->s[k]) strcpy(d->s[k], s0);
        }
    }
    d->time = 0.0;
    d->initialized = 0;
    d->step_count = 0;
}

/* initialize the model on its first read, then compute the calculated values before they are read */
static int refresh_model(ModelData *d)
{
    int st = M_OK;
    if (!d->initialized) st = model_initialize(d);
    if (st <= M_WARNING) model_calc(d);
    return st;
}

#endif

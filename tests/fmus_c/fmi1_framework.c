/*
 * Generic FMI 1.0 Co-Simulation (stand-alone) implementation for the
 * cosim-master test FMUs: the same model files (<Model>.c behind model_api.h)
 * as the FMI 2.0 and 3.0 builds, so that the physics is identical.
 *
 * Written from the FMI 1.0 for Co-Simulation specification for this project,
 * against fmpy's fmi1Functions.h (types only).  FMI 1.0 binaries export every
 * function prefixed with the model identifier (Gain_fmiDoStep), given here by
 * -DMODEL_IDENTIFIER=<name>.  FMI 1.0 has no initialization mode: start values
 * and inputs are set after fmiInstantiateSlave, then fmiInitializeSlave.
 * Getters are also answered before fmiInitializeSlave (with the values derived
 * from the start values), as many FMI 1.0 exporters do.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi1Functions.h"
#include "model_api.h"

#ifndef MODEL_IDENTIFIER
#error "compile with -DMODEL_IDENTIFIER=<modelIdentifier>"
#endif

#define FMI1_PASTE(a, b) a##b
#define FMI1_PASTE2(a, b) FMI1_PASTE(a, b)
/* FMI1_FN(DoStep) -> <MODEL_IDENTIFIER>_fmiDoStep; FMI1_EXPORT: exported despite -fvisibility=hidden */
#define FMI1_FN(name) FMI1_PASTE2(MODEL_IDENTIFIER, _fmi##name)
#define FMI1_EXPORT __attribute__((visibility("default")))

typedef enum { ST_INSTANTIATED = 1, ST_STEP = 2, ST_TERMINATED = 3, ST_ERROR = 4, ST_FATAL = 5 } FwState;

typedef struct {
    ModelData d; /* must be first */
    char *instanceName;
    fmi1CallbackFunctions cb;
    int loggingOn;
    FwState state;
} Instance;

static const char *status_category(int status)
{
    switch (status) {
    case M_OK: return "logAll";
    case M_WARNING: return "logStatusWarning";
    case M_DISCARD: return "logStatusDiscard";
    case M_ERROR: return "logStatusError";
    default: return "logStatusFatal";
    }
}

void fw_log(ModelData *d, int status, const char *category, const char *fmt, ...)
{
    Instance *inst = (Instance *)d->fw;
    char buf[1024];
    char esc[2 * sizeof buf];
    size_t i, j;
    va_list ap;
    if (inst == NULL || inst->cb.logger == NULL) return;
    if (status == M_OK && !inst->loggingOn) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* the FMI 1.0 logger, too, treats the message as a printf format string */
    for (i = 0, j = 0; buf[i] != '\0' && j + 2 < sizeof esc; i++) {
        if (buf[i] == '%') esc[j++] = '%';
        esc[j++] = buf[i];
    }
    esc[j] = '\0';
    inst->cb.logger(inst, inst->instanceName, (fmi1Status)status, category ? category : status_category(status),
                    esc);
}

#define LOGE(inst, ...) fw_log(&(inst)->d, M_ERROR, "logStatusError", __VA_ARGS__)

#include "framework_common.h"

static int refresh(Instance *inst)
{
    return refresh_model(&inst->d);
}

/* ------------------------------------------------------------------------ */
/* Life cycle                                                                */

const char *FMI1_FN(GetTypesPlatform)(void) { return "standard32"; }
const char *FMI1_FN(GetVersion)(void) { return "1.0"; }

FMI1_EXPORT fmi1Status FMI1_FN(SetDebugLogging)(fmi1Component c, fmi1Boolean loggingOn)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmiSetDebugLogging", ANY_STATE) > fmi1Warning) return fmi1Error;
    inst->loggingOn = loggingOn ? 1 : 0;
    return fmi1OK;
}

FMI1_EXPORT fmi1Component FMI1_FN(InstantiateSlave)(fmi1String instanceName, fmi1String fmuGUID, fmi1String fmuLocation,
                                        fmi1String mimeType, fmi1Real timeout, fmi1Boolean visible,
                                        fmi1Boolean interactive, fmi1CallbackFunctions functions,
                                        fmi1Boolean loggingOn)
{
    Instance *inst;
    (void)mimeType;
    (void)timeout;
    (void)visible;
    (void)interactive;
    if (functions.logger == NULL) return NULL;
    if (instanceName == NULL || instanceName[0] == '\0') {
        functions.logger(NULL, "?", fmi1Error, "logStatusError", "fmiInstantiateSlave: missing instance name");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL_GUID) != 0) {
        functions.logger(NULL, instanceName, fmi1Error, "logStatusError",
                         "fmiInstantiateSlave: wrong GUID (expected " MODEL_GUID ")");
        return NULL;
    }
    if (fmuLocation == NULL || strncmp(fmuLocation, "file:", 5) != 0) {
        functions.logger(NULL, instanceName, fmi1Error, "logStatusError",
                         "fmiInstantiateSlave: fmuLocation is not a file URI");
        return NULL;
    }
    inst = (Instance *)calloc(1, sizeof(Instance));
    if (inst == NULL) return NULL;
    inst->instanceName = (char *)malloc(strlen(instanceName) + 1);
    if (inst->instanceName == NULL) {
        free(inst);
        return NULL;
    }
    strcpy(inst->instanceName, instanceName);
    inst->cb = functions;
    inst->loggingOn = loggingOn ? 1 : 0;
    inst->d.fw = inst;
    load_start_values(inst);
    inst->state = ST_INSTANTIATED;
    return inst;
}

FMI1_EXPORT fmi1Status FMI1_FN(InitializeSlave)(fmi1Component c, fmi1Real tStart, fmi1Boolean StopTimeDefined, fmi1Real tStop)
{
    Instance *inst = (Instance *)c;
    int st;
    (void)StopTimeDefined;
    (void)tStop;
    if (check(inst, "fmiInitializeSlave", MASK(ST_INSTANTIATED)) != fmi1OK) return fmi1Error;
    inst->d.time = tStart;
    st = model_initialize(&inst->d);
    if (st > M_WARNING) {
        inst->state = ST_ERROR;
        return (fmi1Status)st;
    }
    inst->d.initialized = 1;
    model_calc(&inst->d);
    inst->state = ST_STEP;
    return (fmi1Status)st;
}

FMI1_EXPORT fmi1Status FMI1_FN(TerminateSlave)(fmi1Component c)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmiTerminateSlave", MASK(ST_STEP)) != fmi1OK) return fmi1Error;
    inst->state = ST_TERMINATED;
    return fmi1OK;
}

FMI1_EXPORT fmi1Status FMI1_FN(ResetSlave)(fmi1Component c)
{
    Instance *inst = (Instance *)c;
    if (inst == NULL) return fmi1Error;
    load_start_values(inst);
    inst->state = ST_INSTANTIATED;
    return fmi1OK;
}

FMI1_EXPORT void FMI1_FN(FreeSlaveInstance)(fmi1Component c)
{
    Instance *inst = (Instance *)c;
    int k;
    if (inst == NULL) return;
    for (k = 0; k < NVARS; k++) free(inst->d.s[k]);
    free(inst->instanceName);
    free(inst);
}

/* ------------------------------------------------------------------------ */
/* Getters and setters                                                       */

static fmi1Status check_vr(Instance *inst, const char *fname, fmi1ValueReference vr, int type)
{
    if (vr >= (fmi1ValueReference)NVARS || VAR_TYPE[vr] != type) {
        LOGE(inst, "%s: unknown value reference %u for this type", fname, (unsigned)vr);
        return fmi1Error;
    }
    return fmi1OK;
}

static fmi1Status check_settable(Instance *inst, const char *fname, fmi1ValueReference vr)
{
    int mode = VAR_SET_MODE[vr];
    if (mode == SET_ALWAYS || (mode == SET_BEFORE_RUN && inst->state == ST_INSTANTIATED)) return fmi1OK;
    LOGE(inst, "%s: variable with value reference %u cannot be set in this state", fname, (unsigned)vr);
    return fmi1Error;
}

#define GET_STATES (MASK(ST_INSTANTIATED) | MASK(ST_STEP) | MASK(ST_TERMINATED) | MASK(ST_ERROR))
#define SET_STATES (MASK(ST_INSTANTIATED) | MASK(ST_STEP))

/* the body shared by the four getters: `store` copies variable vr[k] into value[k] */
#define GETTER(fname, type, store)                                                \
    Instance *inst = (Instance *)c;                                               \
    size_t k;                                                                     \
    if (check(inst, fname, GET_STATES) != fmi1OK) return fmi1Error;               \
    if (nvr == 0) return fmi1OK;                                                  \
    if (refresh(inst) > M_WARNING) return fmi1Error;                              \
    for (k = 0; k < nvr; k++) {                                                   \
        if (check_vr(inst, fname, vr[k], type) != fmi1OK) return fmi1Error;       \
        store;                                                                    \
    }                                                                             \
    return fmi1OK;

/* the body shared by the numeric setters: `store` copies value[k] into variable vr[k] */
#define SETTER(fname, type, store)                                                \
    Instance *inst = (Instance *)c;                                               \
    size_t k;                                                                     \
    if (check(inst, fname, SET_STATES) != fmi1OK) return fmi1Error;               \
    for (k = 0; k < nvr; k++) {                                                   \
        if (check_vr(inst, fname, vr[k], type) != fmi1OK) return fmi1Error;       \
        if (check_settable(inst, fname, vr[k]) != fmi1OK) return fmi1Error;       \
        store;                                                                    \
    }                                                                             \
    return fmi1OK;

FMI1_EXPORT fmi1Status FMI1_FN(GetReal)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr, fmi1Real value[])
{
    GETTER("fmiGetReal", T_REAL, value[k] = inst->d.r[vr[k]])
}

FMI1_EXPORT fmi1Status FMI1_FN(GetInteger)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr, fmi1Integer value[])
{
    GETTER("fmiGetInteger", T_INTEGER, value[k] = inst->d.i[vr[k]])
}

FMI1_EXPORT fmi1Status FMI1_FN(GetBoolean)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr, fmi1Boolean value[])
{
    GETTER("fmiGetBoolean", T_BOOLEAN, value[k] = inst->d.b[vr[k]] ? fmi1True : fmi1False)
}

FMI1_EXPORT fmi1Status FMI1_FN(GetString)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr, fmi1String value[])
{
    GETTER("fmiGetString", T_STRING, value[k] = inst->d.s[vr[k]] ? inst->d.s[vr[k]] : "")
}

FMI1_EXPORT fmi1Status FMI1_FN(SetReal)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr, const fmi1Real value[])
{
    SETTER("fmiSetReal", T_REAL, inst->d.r[vr[k]] = value[k])
}

FMI1_EXPORT fmi1Status FMI1_FN(SetInteger)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                               const fmi1Integer value[])
{
    SETTER("fmiSetInteger", T_INTEGER, inst->d.i[vr[k]] = value[k])
}

FMI1_EXPORT fmi1Status FMI1_FN(SetBoolean)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                               const fmi1Boolean value[])
{
    SETTER("fmiSetBoolean", T_BOOLEAN, inst->d.b[vr[k]] = value[k] ? 1 : 0)
}

static fmi1Status set_string(Instance *inst, fmi1ValueReference vr, const char *v)
{
    char *copy = (char *)malloc(strlen(v ? v : "") + 1);
    if (copy == NULL) {
        LOGE(inst, "fmiSetString: out of memory");
        return fmi1Error;
    }
    strcpy(copy, v ? v : "");
    free(inst->d.s[vr]);
    inst->d.s[vr] = copy;
    return fmi1OK;
}

FMI1_EXPORT fmi1Status FMI1_FN(SetString)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr, const fmi1String value[])
{
    SETTER("fmiSetString", T_STRING, if (set_string(inst, vr[k], value[k]) != fmi1OK) return fmi1Error)
}

/* ------------------------------------------------------------------------ */
/* Stepping                                                                  */

static fmi1Status unsupported(fmi1Component c, const char *fname)
{
    Instance *inst = (Instance *)c;
    if (inst != NULL) LOGE(inst, "%s is not supported by this FMU", fname);
    return fmi1Error;
}

FMI1_EXPORT fmi1Status FMI1_FN(SetRealInputDerivatives)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                            const fmi1Integer order[], const fmi1Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmiSetRealInputDerivatives (canInterpolateInputs=false)");
}

FMI1_EXPORT fmi1Status FMI1_FN(GetRealOutputDerivatives)(fmi1Component c, const fmi1ValueReference vr[], size_t nvr,
                                             const fmi1Integer order[], fmi1Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmiGetRealOutputDerivatives (maxOutputDerivativeOrder=0)");
}

FMI1_EXPORT fmi1Status FMI1_FN(CancelStep)(fmi1Component c) { return unsupported(c, "fmiCancelStep (doStep is synchronous)"); }

FMI1_EXPORT fmi1Status FMI1_FN(DoStep)(fmi1Component c, fmi1Real currentCommunicationPoint, fmi1Real communicationStepSize,
                           fmi1Boolean newStep)
{
    Instance *inst = (Instance *)c;
    int st;
    double tol;
    (void)newStep;
    if (check(inst, "fmiDoStep", MASK(ST_STEP)) != fmi1OK) return fmi1Error;
    if (!(communicationStepSize > 0.0)) {
        LOGE(inst, "fmiDoStep: communicationStepSize must be > 0 (got %g)", communicationStepSize);
        return fmi1Error;
    }
    tol = 1e-8 * (fabs(currentCommunicationPoint) > 1.0 ? fabs(currentCommunicationPoint) : 1.0);
    if (fabs(currentCommunicationPoint - inst->d.time) > tol) {
        LOGE(inst, "fmiDoStep: currentCommunicationPoint %.17g does not match the FMU time %.17g",
             currentCommunicationPoint, inst->d.time);
        return fmi1Error;
    }
    st = model_do_step(&inst->d, currentCommunicationPoint, communicationStepSize);
    if (st <= M_WARNING) {
        inst->d.time = currentCommunicationPoint + communicationStepSize;
        inst->d.step_count++;
        model_calc(&inst->d);
    } else if (st == M_ERROR) {
        inst->state = ST_ERROR;
    } else if (st >= M_FATAL) {
        inst->state = ST_FATAL;
    }
    return (fmi1Status)st;
}

FMI1_EXPORT fmi1Status FMI1_FN(GetStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Status *value)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmiGetStatus", ANY_STATE) != fmi1OK) return fmi1Error;
    if (s == fmi1DoStepStatus) {
        *value = fmi1OK; /* doStep never returns fmiPending */
        return fmi1OK;
    }
    return fmi1Discard;
}

FMI1_EXPORT fmi1Status FMI1_FN(GetRealStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Real *value)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmiGetRealStatus", ANY_STATE) != fmi1OK) return fmi1Error;
    if (s == fmi1LastSuccessfulTime) {
        *value = inst->d.time;
        return fmi1OK;
    }
    return fmi1Discard;
}

FMI1_EXPORT fmi1Status FMI1_FN(GetIntegerStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Integer *value)
{
    (void)s;
    (void)value;
    return check((Instance *)c, "fmiGetIntegerStatus", ANY_STATE) != fmi1OK ? fmi1Error : fmi1Discard;
}

FMI1_EXPORT fmi1Status FMI1_FN(GetBooleanStatus)(fmi1Component c, const fmi1StatusKind s, fmi1Boolean *value)
{
    (void)s;
    (void)value;
    return check((Instance *)c, "fmiGetBooleanStatus", ANY_STATE) != fmi1OK ? fmi1Error : fmi1Discard;
}

FMI1_EXPORT fmi1Status FMI1_FN(GetStringStatus)(fmi1Component c, const fmi1StatusKind s, fmi1String *value)
{
    (void)s;
    (void)value;
    return check((Instance *)c, "fmiGetStringStatus", ANY_STATE) != fmi1OK ? fmi1Error : fmi1Discard;
}

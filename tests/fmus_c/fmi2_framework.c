/*
 * Generic FMI 2.0 implementation (Co-Simulation and Model Exchange) for the
 * cosim-master test FMUs.  The model equations live in <Model>.c behind the
 * small interface of model_api.h; variable tables come from the generated
 * model_vars.h.
 *
 * Written from the FMI 2.0.4 specification for this project.
 * FMU state: get/set/free copy the model data (strings deep) when the model
 * is built with FW_CAN_SAVE_STATE (canGetAndSetFMUstate="true", for the
 * rollback of iterative coupling); otherwise, and for serialization always,
 * they return fmi2Error.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_api.h"

typedef enum {
    ST_INSTANTIATED = 1,
    ST_INIT = 2,
    ST_STEP = 3,       /* CS: stepping; ME: continuous time mode */
    ST_EVENT = 4,      /* ME event mode */
    ST_TERMINATED = 5,
    ST_ERROR = 6,
    ST_FATAL = 7
} FwState;

typedef struct {
    ModelData d; /* must be first */
    char *instanceName;
    fmi2Type type;
    fmi2CallbackFunctions cb;
    int loggingOn;
    FwState state;
    double startTime;
    double stopTime;
    int stopTimeDefined;
    int terminated; /* set when doStep returned fmi2Discard: the slave wants to stop */
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
    va_list ap;
    if (inst == NULL || inst->cb.logger == NULL) return;
    if (status == M_OK && !inst->loggingOn) return;
    char esc[2 * sizeof buf];
    size_t i, j;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* the FMI 2.0 logger treats the message as a printf format string */
    for (i = 0, j = 0; buf[i] != '\0' && j + 2 < sizeof esc; i++) {
        if (buf[i] == '%') esc[j++] = '%';
        esc[j++] = buf[i];
    }
    esc[j] = '\0';
    inst->cb.logger(inst->cb.componentEnvironment, inst->instanceName, (fmi2Status)status,
                    category ? category : status_category(status), esc);
}

#define LOGE(inst, ...) fw_log(&(inst)->d, M_ERROR, "logStatusError", __VA_ARGS__)


#include "framework_common.h"

static int refresh(Instance *inst)
{
    return refresh_model(&inst->d);
}

/* ------------------------------------------------------------------------ */
/* Common functions                                                          */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    Instance *inst = (Instance *)c;
    (void)nCategories;
    (void)categories;
    if (check(inst, "fmi2SetDebugLogging", ANY_STATE) > fmi2Warning) return fmi2Error;
    inst->loggingOn = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    Instance *inst;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL || functions->logger == NULL) return NULL;
    if (instanceName == NULL || instanceName[0] == '\0') {
        functions->logger(functions->componentEnvironment, "?", fmi2Error, "logStatusError",
                          "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL_GUID) != 0) {
        functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                          "fmi2Instantiate: wrong GUID (expected " MODEL_GUID ")");
        return NULL;
    }
    if (!((fmuType == fmi2CoSimulation && MODEL_SUPPORTS_CS) ||
          (fmuType == fmi2ModelExchange && MODEL_SUPPORTS_ME))) {
        functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                          "fmi2Instantiate: this FMU does not support the requested interface type");
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
    inst->type = fmuType;
    inst->cb = *functions;
    inst->loggingOn = loggingOn ? 1 : 0;
    inst->d.fw = inst;
    load_start_values(inst);
    inst->state = ST_INSTANTIATED;
    fw_log(&inst->d, M_OK, "logAll", "fmi2Instantiate: %s (%s)", MODEL_NAME,
           fmuType == fmi2CoSimulation ? "CoSimulation" : "ModelExchange");
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    int k;
    if (inst == NULL) return;
    for (k = 0; k < NVARS; k++) free(inst->d.s[k]);
    free(inst->instanceName);
    free(inst);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    Instance *inst = (Instance *)c;
    (void)toleranceDefined;
    (void)tolerance;
    if (check(inst, "fmi2SetupExperiment", MASK(ST_INSTANTIATED)) != fmi2OK) return fmi2Error;
    inst->startTime = startTime;
    inst->stopTime = stopTime;
    inst->stopTimeDefined = stopTimeDefined ? 1 : 0;
    inst->d.time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2EnterInitializationMode", MASK(ST_INSTANTIATED)) != fmi2OK) return fmi2Error;
    inst->state = ST_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    int st;
    if (check(inst, "fmi2ExitInitializationMode", MASK(ST_INIT)) != fmi2OK) return fmi2Error;
    st = model_initialize(&inst->d);
    if (st > M_WARNING) {
        inst->state = ST_ERROR;
        return (fmi2Status)st;
    }
    inst->d.initialized = 1;
    model_calc(&inst->d);
    inst->state = (inst->type == fmi2ModelExchange) ? ST_EVENT : ST_STEP;
    return (fmi2Status)st;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    /* FMI 2.0: after Error only fmi2FreeInstance and fmi2Reset */
    if (check(inst, "fmi2Terminate", MASK(ST_STEP) | MASK(ST_EVENT)) != fmi2OK)
        return fmi2Error;
    inst->state = ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (inst == NULL) return fmi2Error;
    load_start_values(inst);
    inst->terminated = 0;
    inst->state = ST_INSTANTIATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------------ */
/* Getters and setters                                                       */

static fmi2Status check_vr(Instance *inst, const char *fname, fmi2ValueReference vr, int type)
{
    if (vr >= (fmi2ValueReference)NVARS || VAR_TYPE[vr] != type) {
        LOGE(inst, "%s: unknown value reference %u for this type", fname, (unsigned)vr);
        return fmi2Error;
    }
    return fmi2OK;
}

static fmi2Status check_settable(Instance *inst, const char *fname, fmi2ValueReference vr)
{
    int mode = VAR_SET_MODE[vr];
    if (mode == SET_ALWAYS) return fmi2OK;
    if (mode == SET_BEFORE_RUN && (inst->state == ST_INSTANTIATED || inst->state == ST_INIT))
        return fmi2OK;
    LOGE(inst, "%s: variable with value reference %u cannot be set in this state", fname, (unsigned)vr);
    return fmi2Error;
}

#define GET_STATES (MASK(ST_INIT) | MASK(ST_STEP) | MASK(ST_EVENT) | MASK(ST_TERMINATED) | MASK(ST_ERROR))
#define SET_STATES (MASK(ST_INSTANTIATED) | MASK(ST_INIT) | MASK(ST_STEP) | MASK(ST_EVENT))

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetReal", GET_STATES) != fmi2OK) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    if (refresh(inst) > M_WARNING) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2GetReal", vr[k], T_REAL) != fmi2OK) return fmi2Error;
        value[k] = inst->d.r[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetInteger", GET_STATES) != fmi2OK) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    if (refresh(inst) > M_WARNING) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2GetInteger", vr[k], T_INTEGER) != fmi2OK) return fmi2Error;
        value[k] = inst->d.i[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetBoolean", GET_STATES) != fmi2OK) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    if (refresh(inst) > M_WARNING) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2GetBoolean", vr[k], T_BOOLEAN) != fmi2OK) return fmi2Error;
        value[k] = inst->d.b[vr[k]] ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetString", GET_STATES) != fmi2OK) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    if (refresh(inst) > M_WARNING) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2GetString", vr[k], T_STRING) != fmi2OK) return fmi2Error;
        value[k] = inst->d.s[vr[k]] ? inst->d.s[vr[k]] : "";
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2SetReal", SET_STATES) != fmi2OK) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2SetReal", vr[k], T_REAL) != fmi2OK) return fmi2Error;
        if (check_settable(inst, "fmi2SetReal", vr[k]) != fmi2OK) return fmi2Error;
        inst->d.r[vr[k]] = value[k];
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2SetInteger", SET_STATES) != fmi2OK) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2SetInteger", vr[k], T_INTEGER) != fmi2OK) return fmi2Error;
        if (check_settable(inst, "fmi2SetInteger", vr[k]) != fmi2OK) return fmi2Error;
        inst->d.i[vr[k]] = value[k];
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2SetBoolean", SET_STATES) != fmi2OK) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        if (check_vr(inst, "fmi2SetBoolean", vr[k], T_BOOLEAN) != fmi2OK) return fmi2Error;
        if (check_settable(inst, "fmi2SetBoolean", vr[k]) != fmi2OK) return fmi2Error;
        inst->d.b[vr[k]] = value[k] ? 1 : 0;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2SetString", SET_STATES) != fmi2OK) return fmi2Error;
    for (k = 0; k < nvr; k++) {
        const char *v = value[k] ? value[k] : "";
        char *copy;
        if (check_vr(inst, "fmi2SetString", vr[k], T_STRING) != fmi2OK) return fmi2Error;
        if (check_settable(inst, "fmi2SetString", vr[k]) != fmi2OK) return fmi2Error;
        copy = (char *)malloc(strlen(v) + 1);
        if (copy == NULL) {
            LOGE(inst, "fmi2SetString: out of memory");
            return fmi2Error;
        }
        strcpy(copy, v);
        free(inst->d.s[vr[k]]);
        inst->d.s[vr[k]] = copy;
    }
    return fmi2OK;
}

/* ------------------------------------------------------------------------ */
/* FMU state                                                                 */

static fmi2Status unsupported(fmi2Component c, const char *fname)
{
    Instance *inst = (Instance *)c;
    if (inst != NULL) LOGE(inst, "%s is not supported by this FMU", fname);
    return fmi2Error;
}

#ifdef FW_CAN_SAVE_STATE
/* A saved state: the model data plus the framework state that doStep changes. */
typedef struct {
    ModelData d;
    FwState state;
    int terminated;
} SavedState;

static void copy_strings(char **dst, char *const *src)
{
    int k;
    for (k = 0; k < NVARS; k++) dst[k] = src[k] ? strdup(src[k]) : NULL;
}

static void free_strings(char **s)
{
    int k;
    for (k = 0; k < NVARS; k++) {
        free(s[k]);
        s[k] = NULL;
    }
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    Instance *inst = (Instance *)c;
    SavedState *saved;
    fmi2Status st = check(inst, "fmi2GetFMUstate", ANY_STATE & ~MASK(ST_ERROR));
    if (st != fmi2OK) return st;
    /* FMI 2.0: a non-NULL *FMUstate is a state of this instance to be overwritten */
    saved = *FMUstate ? (SavedState *)*FMUstate : (SavedState *)calloc(1, sizeof *saved);
    if (saved == NULL) {
        LOGE(inst, "fmi2GetFMUstate: out of memory");
        return fmi2Error;
    }
    if (*FMUstate) free_strings(saved->d.s);
    saved->d = inst->d;
    copy_strings(saved->d.s, inst->d.s);
    saved->state = inst->state;
    saved->terminated = inst->terminated;
    *FMUstate = saved;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    Instance *inst = (Instance *)c;
    const SavedState *saved = (const SavedState *)FMUstate;
    fmi2Status st = check(inst, "fmi2SetFMUstate", ANY_STATE & ~MASK(ST_ERROR));
    if (st != fmi2OK) return st;
    if (saved == NULL) {
        LOGE(inst, "fmi2SetFMUstate: no state given");
        return fmi2Error;
    }
    free_strings(inst->d.s);
    inst->d = saved->d;
    copy_strings(inst->d.s, saved->d.s);
    inst->d.fw = inst;
    inst->state = saved->state;
    inst->terminated = saved->terminated;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    SavedState *saved = FMUstate ? (SavedState *)*FMUstate : NULL;
    (void)c;
    if (saved != NULL) {
        free_strings(saved->d.s);
        free(saved);
        *FMUstate = NULL;
    }
    return fmi2OK;
}
#else
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return unsupported(c, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    return unsupported(c, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return unsupported(c, "fmi2FreeFMUstate");
}
#endif

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate;
    (void)size;
    return unsupported(c, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    (void)FMUstate;
    (void)serializedState;
    (void)size;
    return unsupported(c, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState;
    (void)size;
    (void)FMUstate;
    return unsupported(c, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}

/* ------------------------------------------------------------------------ */
/* Model Exchange                                                            */

#define ME_ONLY(inst, fname)                                                    \
    do {                                                                        \
        if ((inst)->type != fmi2ModelExchange) {                                \
            LOGE(inst, "%s: only available for Model Exchange instances", fname); \
            return fmi2Error;                                                   \
        }                                                                       \
    } while (0)

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2EnterEventMode", MASK(ST_STEP) | MASK(ST_EVENT)) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2EnterEventMode");
    inst->state = ST_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2NewDiscreteStates", MASK(ST_EVENT)) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2NewDiscreteStates");
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2EnterContinuousTimeMode", MASK(ST_EVENT)) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2EnterContinuousTimeMode");
    inst->state = ST_STEP;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    Instance *inst = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (check(inst, "fmi2CompletedIntegratorStep", MASK(ST_STEP)) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2CompletedIntegratorStep");
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    inst->d.step_count++;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2SetTime", MASK(ST_INSTANTIATED) | MASK(ST_INIT) | MASK(ST_STEP) | MASK(ST_EVENT)) != fmi2OK)
        return fmi2Error;
    ME_ONLY(inst, "fmi2SetTime");
    inst->d.time = time;
    return fmi2OK;
}

static fmi2Status check_nx(Instance *inst, const char *fname, size_t nx)
{
    if (nx != (size_t)N_STATES) {
        LOGE(inst, "%s: expected %d continuous states, got %u", fname, N_STATES, (unsigned)nx);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2SetContinuousStates", MASK(ST_STEP)) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2SetContinuousStates");
    if (check_nx(inst, "fmi2SetContinuousStates", nx) != fmi2OK) return fmi2Error;
    for (k = 0; k < nx; k++) inst->d.r[STATE_VRS[k]] = x[k];
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetDerivatives", GET_STATES) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2GetDerivatives");
    if (check_nx(inst, "fmi2GetDerivatives", nx) != fmi2OK) return fmi2Error;
    if (refresh(inst) > M_WARNING) return fmi2Error;
    for (k = 0; k < nx; k++) derivatives[k] = inst->d.r[DER_VRS[k]];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    Instance *inst = (Instance *)c;
    (void)eventIndicators;
    if (check(inst, "fmi2GetEventIndicators", GET_STATES) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2GetEventIndicators");
    if (ni != 0) {
        LOGE(inst, "fmi2GetEventIndicators: this model has no event indicators (ni=%u)", (unsigned)ni);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetContinuousStates", GET_STATES) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2GetContinuousStates");
    if (check_nx(inst, "fmi2GetContinuousStates", nx) != fmi2OK) return fmi2Error;
    if (refresh(inst) > M_WARNING) return fmi2Error;
    for (k = 0; k < nx; k++) x[k] = inst->d.r[STATE_VRS[k]];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    Instance *inst = (Instance *)c;
    size_t k;
    if (check(inst, "fmi2GetNominalsOfContinuousStates", ANY_STATE) != fmi2OK) return fmi2Error;
    ME_ONLY(inst, "fmi2GetNominalsOfContinuousStates");
    if (check_nx(inst, "fmi2GetNominalsOfContinuousStates", nx) != fmi2OK) return fmi2Error;
    for (k = 0; k < nx; k++) x_nominal[k] = 1.0;
    return fmi2OK;
}

/* ------------------------------------------------------------------------ */
/* Co-Simulation                                                             */

#define CS_ONLY(inst, fname)                                                     \
    do {                                                                         \
        if ((inst)->type != fmi2CoSimulation) {                                  \
            LOGE(inst, "%s: only available for Co-Simulation instances", fname); \
            return fmi2Error;                                                    \
        }                                                                        \
    } while (0)

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives (canInterpolateInputs=false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder=0)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    Instance *inst = (Instance *)c;
    int st;
    double tol;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (check(inst, "fmi2DoStep", MASK(ST_STEP)) != fmi2OK) return fmi2Error;
    CS_ONLY(inst, "fmi2DoStep");
    if (!(communicationStepSize > 0.0)) {
        LOGE(inst, "fmi2DoStep: communicationStepSize must be > 0 (got %g)", communicationStepSize);
        return fmi2Error;
    }
    tol = 1e-8 * (fabs(currentCommunicationPoint) > 1.0 ? fabs(currentCommunicationPoint) : 1.0);
    if (fabs(currentCommunicationPoint - inst->d.time) > tol) {
        LOGE(inst, "fmi2DoStep: currentCommunicationPoint %.17g does not match the FMU time %.17g",
             currentCommunicationPoint, inst->d.time);
        return fmi2Error;
    }
    st = model_do_step(&inst->d, currentCommunicationPoint, communicationStepSize);
    if (st <= M_WARNING) {
        inst->d.time = currentCommunicationPoint + communicationStepSize;
        inst->d.step_count++;
        model_calc(&inst->d);
    } else if (st == M_DISCARD) {
        /* the step was not performed (time stays at the last successful
         * communication point) and the slave asks to terminate */
        inst->terminated = 1;
    } else if (st == M_ERROR) {
        inst->state = ST_ERROR;
    } else if (st >= M_FATAL) {
        inst->state = ST_FATAL;
    }
    return (fmi2Status)st;
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return unsupported(c, "fmi2CancelStep (doStep is synchronous)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2GetStatus", ANY_STATE) != fmi2OK) return fmi2Error;
    if (s == fmi2DoStepStatus) {
        *value = fmi2OK; /* doStep never returns fmi2Pending */
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2GetRealStatus", ANY_STATE) != fmi2OK) return fmi2Error;
    if (s == fmi2LastSuccessfulTime) {
        *value = inst->d.time;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    Instance *inst = (Instance *)c;
    (void)s;
    (void)value;
    if (check(inst, "fmi2GetIntegerStatus", ANY_STATE) != fmi2OK) return fmi2Error;
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    Instance *inst = (Instance *)c;
    if (check(inst, "fmi2GetBooleanStatus", ANY_STATE) != fmi2OK) return fmi2Error;
    if (s == fmi2Terminated) {
        *value = inst->terminated ? fmi2True : fmi2False;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    Instance *inst = (Instance *)c;
    (void)s;
    (void)value;
    if (check(inst, "fmi2GetStringStatus", ANY_STATE) != fmi2OK) return fmi2Error;
    return fmi2Discard;
}

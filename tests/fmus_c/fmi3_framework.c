/*
 * Generic FMI 3.0 Co-Simulation implementation for the cosim-master test
 * FMUs (scalar variables only: Float64, Int32, Boolean, String).  The model
 * equations live in <Model>.c behind model_api.h; the generated
 * model_vars.h always places the independent variable `time` at VR 0.
 *
 * Written from the FMI 3.0 specification for this project.  Every function
 * declared in fmi3Functions.h is exported; features that are not supported
 * (Model Exchange, Scheduled Execution, FMU state, clocks, derivatives)
 * log an error and return fmi3Error.
 *
 * Event mode and early return: only in models built with FW_EVENT_MODE
 * (hasEventMode="true", mightReturnEarlyFromDoStep="true"), whose equations
 * provide model_step_to_event and model_update_discrete (model_api.h).  With
 * eventModeUsed and earlyReturnAllowed, fmi3DoStep stops at the first event
 * in the step and reports it (eventHandlingNeeded, earlyReturn,
 * lastSuccessfulTime); the importer must then handle it in Event Mode before
 * the next fmi3DoStep, which is checked.  Otherwise the FMU handles its events
 * itself (FMI 3.0: an FMU used without event mode must), and returns early
 * after one when earlyReturnAllowed.  Other builds refuse eventModeUsed.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "model_api.h"

#ifndef VR_time
#error "FMI 3.0 builds need the independent variable time at VR 0"
#endif

typedef enum {
    ST_INSTANTIATED = 1,
    ST_INIT = 2,
    ST_STEP = 3,
    ST_TERMINATED = 4,
    ST_ERROR = 5,
    ST_FATAL = 6,
    ST_EVENT = 7
} FwState;

typedef struct {
    ModelData d; /* must be first */
    char *instanceName;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback logMessage;
    int loggingOn;
    FwState state;
    double stopTime;
    int stopTimeDefined;
    int eventModeUsed;
    int earlyReturnAllowed;
    int eventPending; /* an event was reported to the importer and awaits fmi3UpdateDiscreteStates */
} Instance;

void fw_log(ModelData *d, int status, const char *category, const char *fmt, ...)
{
    Instance *inst = (Instance *)d->fw;
    char buf[1024];
    va_list ap;
    if (inst == NULL || inst->logMessage == NULL) return;
    if (status == M_OK && !inst->loggingOn) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    inst->logMessage(inst->env, (fmi3Status)status, category ? category : "logAll", buf);
}

#define LOGE(inst, ...) fw_log(&(inst)->d, M_ERROR, "logStatusError", __VA_ARGS__)

#include "framework_common.h"

static int refresh(Instance *inst)
{
    int st = refresh_model(&inst->d);
    inst->d.r[VR_time] = inst->d.time;
    return st;
}

static fmi3Status unsupported(fmi3Instance instance, const char *fname)
{
    Instance *inst = (Instance *)instance;
    if (inst != NULL) LOGE(inst, "%s is not supported by this FMU", fname);
    return fmi3Error;
}

/* ------------------------------------------------------------------------ */
/* Common functions                                                          */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    Instance *inst = (Instance *)instance;
    (void)nCategories;
    (void)categories;
    if (check(inst, "fmi3SetDebugLogging", ANY_STATE) > fmi3Warning) return fmi3Error;
    inst->loggingOn = loggingOn ? 1 : 0;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateModelExchange: this FMU supports Co-Simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    Instance *inst;
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (instanceName == NULL || instanceName[0] == '\0') {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: missing instance name");
        return NULL;
    }
    if (instantiationToken == NULL || strcmp(instantiationToken, MODEL_GUID) != 0) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: wrong instantiationToken (expected " MODEL_GUID ")");
        return NULL;
    }
#ifndef FW_EVENT_MODE
    if (eventModeUsed) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: event mode is not supported (hasEventMode=false)");
        return NULL;
    }
#endif
    inst = (Instance *)calloc(1, sizeof(Instance));
    if (inst == NULL) return NULL;
    inst->instanceName = (char *)malloc(strlen(instanceName) + 1);
    if (inst->instanceName == NULL) {
        free(inst);
        return NULL;
    }
    strcpy(inst->instanceName, instanceName);
    inst->env = instanceEnvironment;
    inst->logMessage = logMessage;
    inst->loggingOn = loggingOn ? 1 : 0;
    inst->eventModeUsed = eventModeUsed ? 1 : 0;
    inst->earlyReturnAllowed = earlyReturnAllowed ? 1 : 0;
    inst->d.fw = inst;
    load_start_values(inst);
    inst->state = ST_INSTANTIATED;
    return inst;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: this FMU supports Co-Simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    Instance *inst = (Instance *)instance;
    int k;
    if (inst == NULL) return;
    for (k = 0; k < NVARS; k++) free(inst->d.s[k]);
    free(inst->instanceName);
    free(inst);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    Instance *inst = (Instance *)instance;
    (void)toleranceDefined;
    (void)tolerance;
    if (check(inst, "fmi3EnterInitializationMode", MASK(ST_INSTANTIATED)) != fmi3OK) return fmi3Error;
    inst->d.time = startTime;
    inst->stopTime = stopTime;
    inst->stopTimeDefined = stopTimeDefined ? 1 : 0;
    inst->state = ST_INIT;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    Instance *inst = (Instance *)instance;
    int st;
    if (check(inst, "fmi3ExitInitializationMode", MASK(ST_INIT)) != fmi3OK) return fmi3Error;
    st = model_initialize(&inst->d);
    if (st > M_WARNING) {
        inst->state = ST_ERROR;
        return (fmi3Status)st;
    }
    inst->d.initialized = 1;
    refresh(inst);
    /* FMI 3.0: with eventModeUsed the FMU leaves initialization in Event Mode */
    inst->state = inst->eventModeUsed ? ST_EVENT : ST_STEP;
    return (fmi3Status)st;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
#ifdef FW_EVENT_MODE
    Instance *inst = (Instance *)instance;
    if (check(inst, "fmi3EnterEventMode", MASK(ST_STEP)) != fmi3OK) return fmi3Error;
    if (!inst->eventModeUsed) {
        LOGE(inst, "fmi3EnterEventMode: the FMU was instantiated without eventModeUsed");
        return fmi3Error;
    }
    inst->state = ST_EVENT;
    return fmi3OK;
#else
    return unsupported(instance, "fmi3EnterEventMode (hasEventMode=false)");
#endif
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    Instance *inst = (Instance *)instance;
    if (check(inst, "fmi3Terminate", MASK(ST_STEP) | MASK(ST_EVENT) | MASK(ST_ERROR)) != fmi3OK) return fmi3Error;
    inst->state = ST_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    Instance *inst = (Instance *)instance;
    if (inst == NULL) return fmi3Error;
    load_start_values(inst);
    inst->state = ST_INSTANTIATED;
    return fmi3OK;
}

/* ------------------------------------------------------------------------ */
/* Getters and setters                                                       */

#define GET_STATES (MASK(ST_INIT) | MASK(ST_STEP) | MASK(ST_EVENT) | MASK(ST_TERMINATED) | MASK(ST_ERROR))
#define SET_STATES (MASK(ST_INSTANTIATED) | MASK(ST_INIT) | MASK(ST_STEP) | MASK(ST_EVENT))

static fmi3Status check_access(Instance *inst, const char *fname, const fmi3ValueReference vrs[], size_t nvr,
                               size_t nValues, int type, int setting)
{
    size_t k;
    if (check(inst, fname, setting ? SET_STATES : GET_STATES) != fmi3OK) return fmi3Error;
    if (nValues != nvr) {
        LOGE(inst, "%s: only scalar variables: nValues (%u) must equal nValueReferences (%u)", fname,
             (unsigned)nValues, (unsigned)nvr);
        return fmi3Error;
    }
    for (k = 0; k < nvr; k++) {
        fmi3ValueReference vr = vrs[k];
        if (vr >= (fmi3ValueReference)NVARS || VAR_TYPE[vr] != type) {
            LOGE(inst, "%s: unknown value reference %u for this type", fname, (unsigned)vr);
            return fmi3Error;
        }
        if (setting) {
            int mode = VAR_SET_MODE[vr];
            if (!(mode == SET_ALWAYS ||
                  (mode == SET_BEFORE_RUN && (inst->state == ST_INSTANTIATED || inst->state == ST_INIT)))) {
                LOGE(inst, "%s: variable with value reference %u cannot be set in this state", fname, (unsigned)vr);
                return fmi3Error;
            }
        }
    }
    if (!setting && nvr > 0 && refresh(inst) > M_WARNING) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3GetFloat64", valueReferences, nValueReferences, nValues, T_REAL, 0) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) values[k] = inst->d.r[valueReferences[k]];
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3SetFloat64", valueReferences, nValueReferences, nValues, T_REAL, 1) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) inst->d.r[valueReferences[k]] = values[k];
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int32 values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3GetInt32", valueReferences, nValueReferences, nValues, T_INTEGER, 0) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) values[k] = inst->d.i[valueReferences[k]];
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Int32 values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3SetInt32", valueReferences, nValueReferences, nValues, T_INTEGER, 1) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) inst->d.i[valueReferences[k]] = values[k];
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3GetBoolean", valueReferences, nValueReferences, nValues, T_BOOLEAN, 0) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) values[k] = inst->d.b[valueReferences[k]] ? true : false;
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3SetBoolean", valueReferences, nValueReferences, nValues, T_BOOLEAN, 1) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) inst->d.b[valueReferences[k]] = values[k] ? 1 : 0;
    return fmi3OK;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, fmi3String values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3GetString", valueReferences, nValueReferences, nValues, T_STRING, 0) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        const char *s = inst->d.s[valueReferences[k]];
        values[k] = s ? s : "";
    }
    return fmi3OK;
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const fmi3String values[], size_t nValues)
{
    Instance *inst = (Instance *)instance;
    size_t k;
    if (check_access(inst, "fmi3SetString", valueReferences, nValueReferences, nValues, T_STRING, 1) != fmi3OK)
        return fmi3Error;
    for (k = 0; k < nValueReferences; k++) {
        const char *v = values[k] ? values[k] : "";
        char *copy = (char *)malloc(strlen(v) + 1);
        if (copy == NULL) {
            LOGE(inst, "fmi3SetString: out of memory");
            return fmi3Error;
        }
        strcpy(copy, v);
        free(inst->d.s[valueReferences[k]]);
        inst->d.s[valueReferences[k]] = copy;
    }
    return fmi3OK;
}

/* Types without variables in these models: only empty requests succeed. */
#define NO_VARS_OF_TYPE(fname)                                                  \
    do {                                                                        \
        Instance *inst_ = (Instance *)instance;                                 \
        (void)values;                                                           \
        (void)nValues;                                                          \
        (void)valueReferences;                                                  \
        if (inst_ == NULL) return fmi3Error;                                    \
        if (nValueReferences == 0) return fmi3OK;                               \
        LOGE(inst_, "%s: this FMU has no variables of this type", fname);       \
        return fmi3Error;                                                       \
    } while (0)

fmi3Status fmi3GetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float32 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetFloat32");
}
fmi3Status fmi3GetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                       fmi3Int8 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetInt8");
}
fmi3Status fmi3GetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3UInt8 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetUInt8");
}
fmi3Status fmi3GetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int16 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetInt16");
}
fmi3Status fmi3GetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, fmi3UInt16 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetUInt16");
}
fmi3Status fmi3GetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, fmi3UInt32 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetUInt32");
}
fmi3Status fmi3GetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int64 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetInt64");
}
fmi3Status fmi3GetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, fmi3UInt64 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3GetUInt64");
}
fmi3Status fmi3SetFloat32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float32 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetFloat32");
}
fmi3Status fmi3SetInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                       const fmi3Int8 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetInt8");
}
fmi3Status fmi3SetUInt8(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3UInt8 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetUInt8");
}
fmi3Status fmi3SetInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int16 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetInt16");
}
fmi3Status fmi3SetUInt16(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const fmi3UInt16 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetUInt16");
}
fmi3Status fmi3SetUInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const fmi3UInt32 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetUInt32");
}
fmi3Status fmi3SetInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int64 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetInt64");
}
fmi3Status fmi3SetUInt64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const fmi3UInt64 values[], size_t nValues)
{
    NO_VARS_OF_TYPE("fmi3SetUInt64");
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueSizes;
    NO_VARS_OF_TYPE("fmi3GetBinary");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[], const fmi3Binary values[],
                         size_t nValues)
{
    (void)valueSizes;
    NO_VARS_OF_TYPE("fmi3SetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[])
{
    size_t nValues = nValueReferences;
    NO_VARS_OF_TYPE("fmi3GetClock");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[])
{
    size_t nValues = nValueReferences;
    NO_VARS_OF_TYPE("fmi3SetClock");
}

/* ------------------------------------------------------------------------ */
/* Unsupported optional features                                             */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference;
    (void)nDependencies;
    return unsupported(instance, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    return unsupported(instance, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    return unsupported(instance, "fmi3GetFMUState");
}
fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    (void)FMUState;
    return unsupported(instance, "fmi3SetFMUState");
}
fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    return unsupported(instance, "fmi3FreeFMUState");
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    (void)FMUState;
    (void)size;
    return unsupported(instance, "fmi3SerializedFMUStateSize");
}
fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size)
{
    (void)FMUState;
    (void)serializedState;
    (void)size;
    return unsupported(instance, "fmi3SerializeFMUState");
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    (void)serializedState;
    (void)size;
    (void)FMUState;
    return unsupported(instance, "fmi3DeserializeFMUState");
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity)
{
    (void)unknowns;
    (void)nUnknowns;
    (void)knowns;
    (void)nKnowns;
    (void)seed;
    (void)nSeed;
    (void)sensitivity;
    (void)nSensitivity;
    return unsupported(instance, "fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns;
    (void)nUnknowns;
    (void)knowns;
    (void)nKnowns;
    (void)seed;
    (void)nSeed;
    (void)sensitivity;
    (void)nSensitivity;
    return unsupported(instance, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return unsupported(instance, "fmi3EnterConfigurationMode");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return unsupported(instance, "fmi3ExitConfigurationMode");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    (void)qualifiers;
    return unsupported(instance, "fmi3GetIntervalDecimal");
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    (void)qualifiers;
    return unsupported(instance, "fmi3GetIntervalFraction");
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return unsupported(instance, "fmi3GetShiftDecimal");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return unsupported(instance, "fmi3GetShiftFraction");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)intervals;
    return unsupported(instance, "fmi3SetIntervalDecimal");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return unsupported(instance, "fmi3SetIntervalFraction");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)shifts;
    return unsupported(instance, "fmi3SetShiftDecimal");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)counters;
    (void)resolutions;
    return unsupported(instance, "fmi3SetShiftFraction");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    return unsupported(instance, "fmi3EvaluateDiscreteStates");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
#ifdef FW_EVENT_MODE
    Instance *inst = (Instance *)instance;
    int again = 0, terminate = 0, st;
    if (check(inst, "fmi3UpdateDiscreteStates", MASK(ST_EVENT)) != fmi3OK) return fmi3Error;
    st = model_update_discrete(&inst->d, 1, &again, &terminate);
    if (st > M_WARNING) {
        inst->state = st >= M_FATAL ? ST_FATAL : ST_ERROR;
        return (fmi3Status)st;
    }
    inst->eventPending = 0;
    refresh(inst);
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = again ? true : false;
    if (terminateSimulation) *terminateSimulation = terminate ? true : false;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = false;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = false;
    if (nextEventTimeDefined) *nextEventTimeDefined = false;
    if (nextEventTime) *nextEventTime = 0.0;
    return (fmi3Status)st;
#else
    (void)discreteStatesNeedUpdate;
    (void)terminateSimulation;
    (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged;
    (void)nextEventTimeDefined;
    (void)nextEventTime;
    return unsupported(instance, "fmi3UpdateDiscreteStates (hasEventMode=false)");
#endif
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return unsupported(instance, "fmi3EnterContinuousTimeMode (Model Exchange)");
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    (void)enterEventMode;
    (void)terminateSimulation;
    return unsupported(instance, "fmi3CompletedIntegratorStep (Model Exchange)");
}
fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    return unsupported(instance, "fmi3SetTime (Model Exchange)");
}
fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    (void)continuousStates;
    (void)nContinuousStates;
    return unsupported(instance, "fmi3SetContinuousStates (Model Exchange)");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    (void)derivatives;
    (void)nContinuousStates;
    return unsupported(instance, "fmi3GetContinuousStateDerivatives (Model Exchange)");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    (void)eventIndicators;
    (void)nEventIndicators;
    return unsupported(instance, "fmi3GetEventIndicators (Model Exchange)");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    (void)continuousStates;
    (void)nContinuousStates;
    return unsupported(instance, "fmi3GetContinuousStates (Model Exchange)");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates)
{
    (void)nominals;
    (void)nContinuousStates;
    return unsupported(instance, "fmi3GetNominalsOfContinuousStates (Model Exchange)");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    Instance *inst = (Instance *)instance;
    if (inst == NULL) return fmi3Error;
    *nEventIndicators = 0;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    Instance *inst = (Instance *)instance;
    if (inst == NULL) return fmi3Error;
    *nContinuousStates = 0;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
#ifdef FW_EVENT_MODE
    Instance *inst = (Instance *)instance;
    if (check(inst, "fmi3EnterStepMode", MASK(ST_EVENT)) != fmi3OK) return fmi3Error;
    if (inst->eventPending) {
        LOGE(inst, "fmi3EnterStepMode: the event at t=%.17g was not handled (no fmi3UpdateDiscreteStates)",
             inst->d.time);
        return fmi3Error;
    }
    inst->state = ST_STEP;
    return fmi3OK;
#else
    return unsupported(instance, "fmi3EnterStepMode (hasEventMode=false)");
#endif
}

#ifdef FW_EVENT_MODE
/* From t to t + h, or to the first event on the way (see the file's comment); flags as fmi3DoStep's. */
static int step_with_events(Instance *inst, double t, double h, int *eventHandlingNeeded, int *terminateSimulation,
                            int *earlyReturn)
{
    ModelData *d = &inst->d;
    const double end = t + h;
    int st, event, again, terminate, pass;
    double reached;
    d->time = t;
    for (;;) {
        st = model_step_to_event(d, d->time, end - d->time, &reached, &event);
        if (st > M_WARNING) return st;
        d->time = event ? reached : end;
        if (!event) return st;
        if (inst->eventModeUsed && (inst->earlyReturnAllowed || !(reached < end))) {
            /* the importer handles it, at the time reached */
            *eventHandlingNeeded = 1;
            *earlyReturn = reached < end;
            inst->eventPending = 1;
            return st;
        }
        for (pass = 0, again = 1, terminate = 0; again && !terminate; pass++) {
            if (pass == 1000) {
                LOGE(inst, "fmi3DoStep: the event iteration at t=%.17g did not settle", d->time);
                return M_ERROR;
            }
            st = model_update_discrete(d, 0, &again, &terminate);
            if (st > M_WARNING) return st;
        }
        if (terminate) {
            *terminateSimulation = 1;
            *earlyReturn = inst->earlyReturnAllowed && reached < end;
            return st;
        }
        if (inst->earlyReturnAllowed && reached < end) {
            *earlyReturn = 1;
            return st;
        }
    }
}
#endif

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)orders;
    (void)values;
    (void)nValues;
    return unsupported(instance, "fmi3GetOutputDerivatives (maxOutputDerivativeOrder=0)");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    Instance *inst = (Instance *)instance;
    int st;
    double tol;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (check(inst, "fmi3DoStep", MASK(ST_STEP)) != fmi3OK) return fmi3Error;
    if (eventHandlingNeeded) *eventHandlingNeeded = false;
    if (terminateSimulation) *terminateSimulation = false;
    if (earlyReturn) *earlyReturn = false;
    if (!(communicationStepSize > 0.0)) {
        LOGE(inst, "fmi3DoStep: communicationStepSize must be > 0 (got %g)", communicationStepSize);
        return fmi3Error;
    }
    tol = 1e-8 * (fabs(currentCommunicationPoint) > 1.0 ? fabs(currentCommunicationPoint) : 1.0);
    if (fabs(currentCommunicationPoint - inst->d.time) > tol) {
        LOGE(inst, "fmi3DoStep: currentCommunicationPoint %.17g does not match the FMU time %.17g",
             currentCommunicationPoint, inst->d.time);
        return fmi3Error;
    }
#ifdef FW_EVENT_MODE
    if (inst->eventPending) {
        LOGE(inst, "fmi3DoStep: the event at t=%.17g awaits handling in Event Mode (eventHandlingNeeded was returned)",
             inst->d.time);
        return fmi3Error;
    }
    {
        int event = 0, terminate = 0, early = 0;
        st = step_with_events(inst, currentCommunicationPoint, communicationStepSize, &event, &terminate, &early);
        if (eventHandlingNeeded) *eventHandlingNeeded = event ? true : false;
        if (terminateSimulation) *terminateSimulation = terminate ? true : false;
        if (earlyReturn) *earlyReturn = early ? true : false;
    }
#else
    st = model_do_step(&inst->d, currentCommunicationPoint, communicationStepSize);
    if (st <= M_WARNING) inst->d.time = currentCommunicationPoint + communicationStepSize;
#endif
    if (st <= M_WARNING) {
        inst->d.step_count++;
        refresh(inst);
    } else if (st == M_ERROR) {
        inst->state = ST_ERROR;
    } else if (st >= M_FATAL) {
        inst->state = ST_FATAL;
    }
    if (lastSuccessfulTime) *lastSuccessfulTime = inst->d.time;
    return (fmi3Status)st;
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference;
    (void)activationTime;
    return unsupported(instance, "fmi3ActivateModelPartition (Scheduled Execution)");
}

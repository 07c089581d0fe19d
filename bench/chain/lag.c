/*
 * Lag: a first-order lag as an FMI 2.0 Co-Simulation FMU, for the chain benchmark.
 *
 *   x' = (k u - x) / T,  y = x,  x(0) = x0
 *
 * fmi2DoStep performs exactly one explicit Euler step  x += h * (k u - x) / T,
 * so the chain's trajectory follows a closed-form recurrence that the harness
 * recomputes (bench/chain/run_bench.py) and the Python twin (Lag.py) computes
 * with the same operations in the same order.
 *
 * Deliberately cheap: the benchmark measures the master's cost per FMU step.
 * Written from the FMI 2.0.4 specification; every fmi2* function is exported
 * (masters look all of them up when loading), the ones this model does not
 * support return fmi2Error. No global state: any number of instances.
 *
 * Value references (must match build.py's modelDescription.xml):
 *   0 T  (parameter, fixed)   time constant, start 1
 *   1 k  (parameter, fixed)   gain, start 1
 *   2 x0 (parameter, fixed)   initial state, start 1
 *   3 u  (input)              start 0
 *   4 y  (output, calculated)
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define NV 5
enum { VR_T = 0, VR_K = 1, VR_X0 = 2, VR_U = 3, VR_Y = 4 };

typedef struct {
    double r[NV];
    int initialized;
    fmi2CallbackFunctions cb;
    char *name;
} Lag;

static void log_error(Lag *c, const char *msg)
{
    if (c && c->cb.logger)
        c->cb.logger(c->cb.componentEnvironment, c->name, fmi2Error, "logStatusError", msg);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[])
{
    (void)c; (void)on; (void)n; (void)cats;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)guid; (void)resources; (void)visible; (void)loggingOn;
    if (type != fmi2CoSimulation) return NULL;
    Lag *c = calloc(1, sizeof(Lag));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    c->name = strdup(name ? name : "");
    c->r[VR_T] = 1.0;
    c->r[VR_K] = 1.0;
    c->r[VR_X0] = 1.0;
    c->r[VR_U] = 0.0;
    c->r[VR_Y] = c->r[VR_X0];
    return c;
}

void fmi2FreeInstance(fmi2Component c)
{
    Lag *l = (Lag *)c;
    if (!l) return;
    free(l->name);
    free(l);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop)
{
    (void)c; (void)tolDef; (void)tol; (void)start; (void)stopDef; (void)stop;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    Lag *l = (Lag *)c;
    l->r[VR_Y] = l->r[VR_X0];
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    Lag *l = (Lag *)c;
    l->r[VR_Y] = l->r[VR_X0];
    l->initialized = 1;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c)
{
    Lag *l = (Lag *)c;
    l->r[VR_T] = 1.0; l->r[VR_K] = 1.0; l->r[VR_X0] = 1.0; l->r[VR_U] = 0.0; l->r[VR_Y] = 1.0;
    l->initialized = 0;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[])
{
    Lag *l = (Lag *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NV) { log_error(l, "fmi2GetReal: unknown value reference"); return fmi2Error; }
        value[i] = l->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[])
{
    Lag *l = (Lag *)c;
    for (size_t i = 0; i < n; i++) {
        fmi2ValueReference r = vr[i];
        if (r == VR_Y || r >= NV || (l->initialized && r != VR_U)) {
            log_error(l, "fmi2SetReal: variable cannot be set now");
            return fmi2Error;
        }
        l->r[r] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior)
{
    (void)t; (void)noSetPrior;
    Lag *l = (Lag *)c;
    double *r = l->r;
    r[VR_Y] += h * (r[VR_K] * r[VR_U] - r[VR_Y]) / r[VR_T];
    return fmi2OK;
}

/* ---- unsupported (no Integer/Boolean/String variables, no FMU state, no derivatives) ---- */

#define UNSUPPORTED(c) do { log_error((Lag *)(c), "function not supported by the Lag FMU"); return fmi2Error; } while (0)

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)s; UNSUPPORTED(c); }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)s; UNSUPPORTED(c); }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)s; UNSUPPORTED(c); }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { (void)s; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{ (void)s; (void)b; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
{ (void)s; (void)b; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[])
{ (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz; UNSUPPORTED(c); }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real v[])
{ (void)vr; (void)n; (void)order; (void)v; UNSUPPORTED(c); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real v[])
{ (void)vr; (void)n; (void)order; (void)v; UNSUPPORTED(c); }
fmi2Status fmi2CancelStep(fmi2Component c) { UNSUPPORTED(c); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) { (void)k; (void)v; UNSUPPORTED(c); }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) { (void)k; (void)v; UNSUPPORTED(c); }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) { (void)k; (void)v; UNSUPPORTED(c); }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v) { (void)k; (void)v; UNSUPPORTED(c); }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) { (void)k; (void)v; UNSUPPORTED(c); }

/* Model Exchange entry points: exported so that loaders binding every symbol succeed; never used. */
fmi2Status fmi2EnterEventMode(fmi2Component c) { UNSUPPORTED(c); }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) { (void)e; UNSUPPORTED(c); }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { UNSUPPORTED(c); }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean nsp, fmi2Boolean *ev, fmi2Boolean *term)
{ (void)nsp; (void)ev; (void)term; UNSUPPORTED(c); }
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { (void)t; UNSUPPORTED(c); }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) { (void)x; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real d[], size_t n) { (void)d; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real e[], size_t n) { (void)e; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; UNSUPPORTED(c); }
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; UNSUPPORTED(c); }

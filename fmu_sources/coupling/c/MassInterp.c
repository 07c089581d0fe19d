/*
 * MassAInterp / MassBInterp: the two-mass oscillator's halves (as tests/fmus_c/MassA.c and MassB.c, same
 * variables and value references) with inputs that may change within a step: an FMI 2.0 co-simulation FMU with
 * canInterpolateInputs, whose input over a step is the polynomial u + u1 tau + u2 tau^2 / 2 given by
 * fmi2SetRealInputDerivatives (orders 1 and 2; reset to 0 after every doStep, so a step without them holds u),
 * and first output derivatives (fmi2GetRealOutputDerivatives, maxOutputDerivativeOrder 1).
 *
 *   MassAInterp (built with SIDE_B 0): m x'' = -k x + F(tau)                 input F, outputs x, v
 *   MassBInterp (built with SIDE_B 1): m x'' = -(k + kc) x + kc x_in(tau)     input x_in, outputs x, v and
 *                                      F = kc (x - x_in) (direct feedthrough, with the input value set)
 *
 * doStep is exact for the quadratic input: with K the stiffness and f(tau) the force, the particular solution is
 * xp = (f - (m / K) f'') / K (f'''' = 0), the rest y = x - xp is the free oscillation (cos, sin of w tau,
 * w^2 = K / m); K = 0 integrates the polynomial. Self-contained: one file, the FMI 2.0 headers only.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#ifndef SIDE_B
#define SIDE_B 0
#endif

#if SIDE_B
enum { VR_m, VR_k, VR_kc, VR_x0, VR_v0, VR_u, VR_x, VR_v, VR_F, NVARS };
#else
enum { VR_m, VR_k, VR_x0, VR_v0, VR_u, VR_x, VR_v, NVARS };
#endif

typedef enum { INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED } Phase;

typedef struct {
    double r[NVARS];
    double du[3];          /* input derivatives of order 1 and 2 (index 1, 2) for the next step */
    double time;
    Phase phase;
    const fmi2CallbackFunctions *cb;
    char name[64];
} Instance;

static void log_error(Instance *inst, const char *msg)
{
    if (inst->cb && inst->cb->logger)
        inst->cb->logger(inst->cb->componentEnvironment, inst->name, fmi2Error, "logStatusError", msg);
}

static double stiffness(const Instance *in)
{
#if SIDE_B
    return in->r[VR_k] + in->r[VR_kc];
#else
    return in->r[VR_k];
#endif
}

static double input_gain(const Instance *in)
{
#if SIDE_B
    return in->r[VR_kc];
#else
    (void)in;
    return 1.0;
#endif
}

static void calc(Instance *in)
{
#if SIDE_B
    in->r[VR_F] = in->r[VR_kc] * (in->r[VR_x] - in->r[VR_u]);
#else
    (void)in;
#endif
}

static int valid(const Instance *in) { return in->r[VR_m] > 0.0 && stiffness(in) >= 0.0; }

/* x, v after tau = h for m x'' = -K x + f(tau), f = g (u + u1 tau + u2 tau^2 / 2) */
static void propagate(Instance *in, double h)
{
    double m = in->r[VR_m], K = stiffness(in), g = input_gain(in);
    double f0 = g * in->r[VR_u], f1 = g * in->du[1], f2 = g * in->du[2];
    double x0 = in->r[VR_x], v0 = in->r[VR_v];
    if (K == 0.0) {
        in->r[VR_x] = x0 + v0 * h + (f0 * h * h / 2 + f1 * h * h * h / 6 + f2 * h * h * h * h / 24) / m;
        in->r[VR_v] = v0 + (f0 * h + f1 * h * h / 2 + f2 * h * h * h / 6) / m;
        return;
    }
    double w = sqrt(K / m), c = cos(w * h), s = sin(w * h);
    double xp0 = (f0 - m / K * f2) / K, dxp0 = f1 / K;                         /* particular solution at 0 */
    double fh = f0 + f1 * h + f2 * h * h / 2, dfh = f1 + f2 * h;
    double xph = (fh - m / K * f2) / K, dxph = dfh / K;                        /* ... and at h */
    double y0 = x0 - xp0, dy0 = v0 - dxp0;
    in->r[VR_x] = xph + y0 * c + dy0 / w * s;
    in->r[VR_v] = dxph - y0 * w * s + dy0 * c;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[])
{
    (void)c; (void)on; (void)n; (void)cat;
    return fmi2OK;
}

static const double START[NVARS] = {
#if SIDE_B
    1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
#else
    1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0
#endif
};

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging)
{
    (void)guid; (void)res; (void)visible; (void)logging;
    if (type != fmi2CoSimulation) return NULL;
    Instance *in = calloc(1, sizeof(Instance));
    if (!in) return NULL;
    memcpy(in->r, START, sizeof in->r);
    in->cb = cb;
    strncpy(in->name, name ? name : "", sizeof in->name - 1);
    in->phase = INSTANTIATED;
    return in;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop)
{
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    ((Instance *)c)->time = start;
    return fmi2OK;
}

static void initial_state(Instance *in)
{
    in->r[VR_x] = in->r[VR_x0];
    in->r[VR_v] = in->r[VR_v0];
    calc(in);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    Instance *in = c;
    if (!valid(in)) {
        log_error(in, "invalid parameters: m must be > 0 and the stiffness >= 0");
        return fmi2Error;
    }
    in->phase = INITIALIZATION;
    initial_state(in);
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    Instance *in = c;
    initial_state(in);
    in->phase = STEPPING;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { ((Instance *)c)->phase = TERMINATED; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c)
{
    Instance *in = c;
    memcpy(in->r, START, sizeof in->r);
    memset(in->du, 0, sizeof in->du);
    in->phase = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    Instance *in = c;
    if (in->phase == INSTANTIATED || in->phase == INITIALIZATION) initial_state(in);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS) return fmi2Error;
        v[i] = in->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    Instance *in = c;
    for (size_t i = 0; i < n; i++) {
        /* parameters before initialization ends, the input always; never the outputs */
        if (vr[i] >= VR_x || (vr[i] != VR_u && in->phase == STEPPING)) {
            log_error(in, "fmi2SetReal: variable not settable now");
            return fmi2Error;
        }
        in->r[vr[i]] = v[i];
    }
    calc(in);
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{ (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{ (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{ (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
{ (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
{ (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
{ (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    Instance *copy = *state ? *state : malloc(sizeof(Instance));
    if (!copy) return fmi2Error;
    memcpy(copy, c, sizeof(Instance));
    *state = copy;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    Instance *in = c;
    const fmi2CallbackFunctions *cb = in->cb;
    memcpy(in, state, sizeof(Instance));
    in->cb = cb;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    (void)c;
    free(*state);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n)
{ (void)c; (void)s; (void)n; return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{ (void)c; (void)s; (void)b; (void)n; return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
{ (void)c; (void)b; (void)n; (void)s; return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[])
{ (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz; return fmi2Error; }

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    Instance *in = c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] != VR_u || order[i] < 1 || order[i] > 2) {
            log_error(in, "fmi2SetRealInputDerivatives: only the input, orders 1 and 2 (the input is at most quadratic)");
            return fmi2Error;
        }
        in->du[order[i]] = value[i];
    }
    return fmi2OK;
}

/* first derivatives of the outputs at the current time: x' = v, v' = (-K x + g u) / m and, for MassB,
 * F' = kc (v - x_in') with x_in' the input derivative set last (the master sets it before asking) */
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[])
{
    Instance *in = c;
    for (size_t i = 0; i < n; i++) {
        if (order[i] != 1 || vr[i] < VR_x || vr[i] >= NVARS) {
            log_error(in, "fmi2GetRealOutputDerivatives: outputs, order 1 only (maxOutputDerivativeOrder 1)");
            return fmi2Error;
        }
        if (vr[i] == VR_x)
            value[i] = in->r[VR_v];
        else if (vr[i] == VR_v)
            value[i] = (-stiffness(in) * in->r[VR_x] + input_gain(in) * in->r[VR_u]) / in->r[VR_m];
#if SIDE_B
        else
            value[i] = in->r[VR_kc] * (in->r[VR_v] - in->du[1]);
#endif
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior)
{
    Instance *in = c;
    (void)noPrior;
    if (in->phase != STEPPING || !(h > 0.0)) {
        log_error(in, "fmi2DoStep: not initialized or step not positive");
        return fmi2Error;
    }
    propagate(in, h);
    in->du[1] = in->du[2] = 0.0;
    in->time = t + h;
    calc(in);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v)
{
    if (s == fmi2LastSuccessfulTime) { *v = ((Instance *)c)->time; return fmi2OK; }
    return fmi2Discard;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v)
{
    (void)c;
    if (s == fmi2Terminated) { *v = fmi2False; return fmi2OK; }
    return fmi2Discard;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }

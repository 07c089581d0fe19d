/*
 * ControlledTemperature: a stand-in, as an FMI 2.0 Co-Simulation FMU, for the 20-sim ControlledTemperature
 * FMU of the FMI cross-check (Windows binaries only, so it cannot run here): a heated rod of NSEG segments
 * whose far end a PI controller keeps at a sinusoidal set-point. It has the original's shape for the
 * recording benchmark (bench/bench_recording.py): 120 Real variables, cheap steps, and values that change in
 * every step with full-precision digits (temperatures near 293 K), the case that costs a CSV writer most.
 *
 * Value references = position in VARS (build.py writes the same list into modelDescription.xml):
 *   0..9    parameters (fixed): C, G, G_amb, T_amb, T_set0, T_set_amp, period, Kp, Ti, P_max
 *   10..15  T_set, error, integral (locals), u, P_heat, T_sensor (outputs)
 *   16+4i.. segment i: T, der_T, q_in, q_amb (locals), i = 0 .. NSEG-1
 * fmi2DoStep performs one explicit Euler step of size h.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define NSEG 26
#define NV (16 + 4 * NSEG)
enum { C_ = 0, G_, G_AMB, T_AMB, T_SET0, T_SET_AMP, PERIOD, KP, TI, P_MAX,
       T_SET, ERR, INTEGRAL, U, P_HEAT, T_SENSOR, SEG0 };
#define SEG_T(i) (SEG0 + 4 * (i))
#define SEG_DER(i) (SEG0 + 4 * (i) + 1)
#define SEG_QIN(i) (SEG0 + 4 * (i) + 2)
#define SEG_QAMB(i) (SEG0 + 4 * (i) + 3)

static const double START[10] = {0.5, 8.0, 0.35, 293.15, 313.15, 4.0, 5.0, 40.0, 0.8, 200.0};

typedef struct {
    double r[NV];
    int initialized;
    fmi2CallbackFunctions cb;
    char *name;
} Model;

static void log_error(Model *c, const char *msg)
{
    if (c && c->cb.logger)
        c->cb.logger(c->cb.componentEnvironment, c->name, fmi2Error, "logStatusError", msg);
}

/* every variable that is not a parameter, from the states (segment temperatures, integral) at time t */
static void evaluate(Model *m, double t)
{
    double *r = m->r;
    r[T_SET] = r[T_SET0] + r[T_SET_AMP] * sin(2.0 * M_PI * t / r[PERIOD]);
    r[T_SENSOR] = r[SEG_T(NSEG - 1)];
    r[ERR] = r[T_SET] - r[T_SENSOR];
    double u = r[KP] * (r[ERR] + r[INTEGRAL] / r[TI]) / 100.0;
    r[U] = u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
    r[P_HEAT] = r[P_MAX] * r[U];
    for (int i = 0; i < NSEG; i++) {
        r[SEG_QIN(i)] = i == 0 ? r[P_HEAT] : r[G_] * (r[SEG_T(i - 1)] - r[SEG_T(i)]);
        r[SEG_QAMB(i)] = r[G_AMB] * (r[SEG_T(i)] - r[T_AMB]);
    }
    for (int i = 0; i < NSEG; i++) {
        double out = i + 1 < NSEG ? r[SEG_QIN(i + 1)] : 0.0;
        r[SEG_DER(i)] = (r[SEG_QIN(i)] - out - r[SEG_QAMB(i)]) / r[C_];
    }
}

static void reset(Model *m)
{
    memset(m->r, 0, sizeof m->r);
    memcpy(m->r, START, sizeof START);
    for (int i = 0; i < NSEG; i++)
        m->r[SEG_T(i)] = START[T_AMB];
    m->initialized = 0;
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
    Model *c = calloc(1, sizeof(Model));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    c->name = strdup(name ? name : "");
    reset(c);
    evaluate(c, 0.0);
    return c;
}

void fmi2FreeInstance(fmi2Component c)
{
    Model *m = (Model *)c;
    if (!m) return;
    free(m->name);
    free(m);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop)
{
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    evaluate((Model *)c, start);
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    ((Model *)c)->initialized = 1;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c)
{
    reset((Model *)c);
    evaluate((Model *)c, 0.0);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[])
{
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NV) { log_error(m, "fmi2GetReal: unknown value reference"); return fmi2Error; }
        value[i] = m->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[])
{
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= P_MAX + 1 || m->initialized) {
            log_error(m, "fmi2SetReal: variable cannot be set now");
            return fmi2Error;
        }
        m->r[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior)
{
    (void)noSetPrior;
    Model *m = (Model *)c;
    double *r = m->r;
    r[INTEGRAL] += h * r[ERR];
    for (int i = 0; i < NSEG; i++)
        r[SEG_T(i)] += h * r[SEG_DER(i)];
    evaluate(m, t + h);
    return fmi2OK;
}

/* ---- unsupported (no Integer/Boolean/String variables, no FMU state, no derivatives) ---- */

#define UNSUPPORTED(c) do { log_error((Model *)(c), "function not supported by this FMU"); return fmi2Error; } while (0)

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

/* What the benchmarks' hand-written FMI 2.0 FMUs (bench/recording's two ControlledTemperature stand-ins and
 * bench/chain/lag.c) share, in one copy: the error log, the instance's life cycle and the FMI 2.0 functions
 * they do not support (no Integer or String variables, no FMU state, no derivatives, no Model Exchange). The
 * including file defines Model (with cb, name and initialized), reset(Model *) and evaluate(Model *, double t)
 * first, and HAS_NO_BOOLEANS when it has no Boolean variables. */
#ifndef BENCH_FMI2_COMMON_H
#define BENCH_FMI2_COMMON_H

static void log_error(Model *c, const char *msg)
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

#define UNSUPPORTED(c) do { log_error((Model *)(c), "function not supported by this FMU"); return fmi2Error; } while (0)

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
#ifdef HAS_NO_BOOLEANS
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{ (void)vr; (void)v; if (n == 0) return fmi2OK; UNSUPPORTED(c); }
#endif
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

#endif

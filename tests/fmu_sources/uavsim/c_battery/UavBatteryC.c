/*
 * UavBatteryC -- a native C FMI 2.0 Co-Simulation twin of the pythonfmu FMU UavBattery
 * (fmu_sources/UavBattery.py over fmu_sources/uavsim/battery.py), written for
 * tests/fmu_sources/uavsim/test_battery_swap_c.py.  No Python anywhere: only libc and libm.
 *
 * Variables (names, value references, types, causalities, units, start values) are NOT written
 * here: the test generates "UavBatteryC_vars.h" from the Python FMU's own modelDescription.xml
 * (and the OCV table and g from uavsim/params.py), so both FMUs have the same connectors by
 * construction.  The header provides
 *   MODEL_GUID                          the GUID of the generated modelDescription.xml
 *   N_VARS                              number of variables (value references 0 .. N_VARS-1)
 *   VR_<name>                           value reference of every variable
 *   VAR_TYPE[N_VARS]                    'R' Real, 'I' Integer (per value reference)
 *   VAR_KIND[N_VARS]                    'p' parameter, 'i' input, 'o' output
 *   START_REAL[N_VARS], START_INT[N_VARS]  start values (defaults of uavsim/params.py)
 *   UAV_G0, OCV_N, OCV_SOC[OCV_N], OCV_CELL[OCV_N]
 *
 * Model (docs/uav_models.md, "UavBattery"): Zeng et al. (2019) eq. (12) rotary-wing shaft power,
 * climb power m g max(0, vz), motor efficiency, avionics power; electrical power only for avionics
 * on the ground (phases 0, 4); LiPo pack E = cells * OCV(soc) (linear table interpolation),
 * U = E - I R, I from P = U I (maximum-power current when E^2 < 4 R P); coulomb counting on fixed
 * sub-steps (substep, 0.05 s; n = round(dt/h) or ceil when that does not divide the step) with the
 * power demand computed once per master step; energy_used = sum U I h.
 *
 * Floating point: every expression below is written with the same operations in the same order
 * as the Python source (Python evaluates left to right, `**` calls the C library's pow, math.sqrt
 * is the IEEE square root, round() ties to even like nearbyint).  Compile with
 * -ffp-contract=off (no fused multiply-add) and -fno-builtin (pow is called, not folded, e.g.
 * pow(x, 2.0) -> x*x) to make the results bit-identical to the Python model on the same libm.
 *
 * Life cycle as in the pythonfmu shell: the model is built from the start values at
 * instantiation (its outputs are visible during initialization), rebuilt from the parameter
 * values at fmi2ExitInitializationMode, and each fmi2DoStep advances it with the inputs held.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "UavBatteryC_vars.h"

/* ------------------------------------------------------------------ model */

typedef struct {
    /* power model (PowerParams), derived once per build */
    double mass, rho, rotor_radius, solidity, tip_speed, profile_drag_coef, induced_correction;
    double flat_plate_area, efficiency, avionics_power;
    int rotor_count;
    double disc_area, weight, p0, pi_ind, v0;
    /* pack (BatteryParams) */
    int cells;
    double capacity_ah, cell_resistance, initial_soc, substep;
    double resistance, capacity_c;
    /* state */
    double charge_used, energy_used, power, current, voltage;
    int overload;
} Battery;

static double max0(double x) /* Python max(0.0, x) */
{
    return x > 0.0 ? x : 0.0;
}

static double shaft_power(const Battery *b, double v)
{
    double v2 = v * v;
    double v0 = b->v0;
    double blade = b->p0 * (1.0 + 3.0 * v2 / pow(b->tip_speed, 2.0));
    double induced = b->pi_ind * sqrt(max0(sqrt(1.0 + v2 * v2 / (4.0 * pow(v0, 4.0))) - v2 / (2.0 * v0 * v0)));
    double parasite = 0.5 * b->rho * b->flat_plate_area * v2 * fabs(v);
    return blade + induced + parasite;
}

static double electrical_power(const Battery *b, double airspeed, double vz, int motors_on)
{
    if (!motors_on) return b->avionics_power;
    double climb = max0(b->weight * vz);
    return (shaft_power(b, airspeed) + climb) / b->efficiency + b->avionics_power;
}

static double ocv_cell(double soc)
{
    if (soc <= OCV_SOC[0]) return OCV_CELL[0];
    if (soc >= OCV_SOC[OCV_N - 1]) return OCV_CELL[OCV_N - 1];
    int j = 0; /* bisect_right(xs, soc) - 1: the last j with xs[j] <= soc */
    while (j + 1 < OCV_N - 1 && OCV_SOC[j + 1] <= soc) j++;
    double f = (soc - OCV_SOC[j]) / (OCV_SOC[j + 1] - OCV_SOC[j]);
    return OCV_CELL[j] + f * (OCV_CELL[j + 1] - OCV_CELL[j]);
}

static double current_for_power(double power, double emf, double r, int *overload)
{
    *overload = 0;
    if (r <= 0.0) return power / emf;
    double disc = emf * emf - 4.0 * r * power;
    if (disc < 0.0) {
        *overload = 1;
        return emf / (2.0 * r);
    }
    return (emf - sqrt(disc)) / (2.0 * r);
}

static double battery_soc(const Battery *b)
{
    return max0(1.0 - b->charge_used / b->capacity_c);
}

/* current, terminal voltage and delivered power at the electrical power demand */
static void update_power(Battery *b, double demand)
{
    double emf = b->cells * ocv_cell(battery_soc(b));
    b->power = demand;
    b->current = current_for_power(demand, emf, b->resistance, &b->overload);
    b->voltage = emf - b->current * b->resistance;
    b->power = b->voltage * b->current;
}

static void battery_build(Battery *b, const double *r, const int *iv)
{
    b->mass = r[VR_mass];
    b->rho = r[VR_rho];
    b->rotor_radius = r[VR_rotor_radius];
    b->solidity = r[VR_solidity];
    b->tip_speed = r[VR_tip_speed];
    b->profile_drag_coef = r[VR_profile_drag_coef];
    b->induced_correction = r[VR_induced_correction];
    b->flat_plate_area = r[VR_flat_plate_area];
    b->efficiency = r[VR_efficiency];
    b->avionics_power = r[VR_avionics_power];
    b->rotor_count = iv[VR_rotor_count];
    b->cells = iv[VR_cells];
    b->capacity_ah = r[VR_capacity_ah];
    b->cell_resistance = r[VR_cell_resistance];
    b->initial_soc = r[VR_initial_soc];
    b->substep = r[VR_substep];

    b->disc_area = b->rotor_count * M_PI * pow(b->rotor_radius, 2.0);
    b->weight = b->mass * UAV_G0;
    b->p0 = b->profile_drag_coef / 8.0 * b->rho * b->solidity * b->disc_area * pow(b->tip_speed, 3.0);
    b->pi_ind = (1.0 + b->induced_correction) * pow(b->weight, 1.5) / sqrt(2.0 * b->rho * b->disc_area);
    b->v0 = sqrt(b->weight / (2.0 * b->rho * b->disc_area));

    b->resistance = b->cells * b->cell_resistance;
    b->capacity_c = b->capacity_ah * 3600.0;
    b->charge_used = (1.0 - b->initial_soc) * b->capacity_c;
    b->energy_used = 0.0;
    b->power = 0.0;
    b->current = 0.0;
    b->overload = 0;
    b->voltage = b->cells * ocv_cell(battery_soc(b));
    update_power(b, electrical_power(b, 0.0, 0.0, 0));
}

static void battery_step(Battery *b, double dt, double airspeed, double vz, int phase)
{
    if (dt <= 0.0) return;
    int motors_on = phase == 1 || phase == 2 || phase == 3;
    /* sub-steps: n = max(1, round(dt / h0)); if n h0 misses dt, n = ceil(dt / h0 - 1e-9) */
    double h0 = b->substep;
    long n = (long)nearbyint(dt / h0);
    if (n < 1) n = 1;
    if (fabs(n * h0 - dt) > 1e-9 * (dt > 1.0 ? dt : 1.0)) n = (long)ceil(dt / h0 - 1e-9);
    double h = dt / n;

    double demand = electrical_power(b, airspeed, vz, motors_on);
    double r = b->resistance, cap = b->capacity_c;
    double q = b->charge_used, e = b->energy_used;
    double cur = 0.0, volt = 0.0, pw = 0.0;
    int over = 0;
    for (long i = 0; i <= n; i++) {
        double soc = max0(1.0 - q / cap);
        double emf = b->cells * ocv_cell(soc);
        cur = current_for_power(demand, emf, r, &over);
        volt = emf - cur * r;
        pw = volt * cur;
        if (i < n) {
            q += cur * h;
            e += pw * h;
        }
    }
    b->charge_used = q;
    b->energy_used = e;
    b->current = cur;
    b->overload = over;
    b->voltage = volt;
    b->power = pw;
}

/* ------------------------------------------------------------------ FMI 2.0 instance */

typedef enum { S_INSTANTIATED, S_INIT, S_STEP, S_TERMINATED, S_ERROR } State;

typedef struct {
    char *name;
    fmi2CallbackFunctions cb;
    int logging_on;
    State state;
    double r[N_VARS]; /* Real values by value reference */
    int iv[N_VARS];   /* Integer values by value reference */
    Battery bat;
} Instance;

static void logf_(Instance *c, fmi2Status status, const char *fmt, ...)
{
    char buf[512], esc[1024];
    size_t i, j;
    va_list ap;
    if (c == NULL || c->cb.logger == NULL) return;
    if (status == fmi2OK && !c->logging_on) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    for (i = 0, j = 0; buf[i] != '\0' && j + 2 < sizeof esc; i++) { /* the logger formats printf-style */
        if (buf[i] == '%') esc[j++] = '%';
        esc[j++] = buf[i];
    }
    esc[j] = '\0';
    c->cb.logger(c->cb.componentEnvironment, c->name, status,
                 status == fmi2OK ? "logAll" : status == fmi2Warning ? "logStatusWarning" : "logStatusError", esc);
}

static void publish(Instance *c)
{
    const Battery *b = &c->bat;
    double consumed = b->charge_used / b->capacity_c;
    c->r[VR_soc] = max0(1.0 - consumed);
    c->r[VR_consumed] = consumed;
    c->r[VR_voltage] = b->voltage;
    c->r[VR_current] = b->current;
    c->r[VR_power] = b->power;
    c->r[VR_energy_used] = b->energy_used;
    c->iv[VR_depleted] = consumed >= 1.0;
}

static fmi2Status fail(Instance *c, const char *fmt, const char *what, unsigned vr)
{
    logf_(c, fmi2Error, fmt, what, vr);
    return fmi2Error;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                              fmi2String resourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)resourceLocation; /* none needed: libcosim passes NULL, that is fine */
    (void)visible;
    if (functions == NULL || instanceName == NULL) return NULL;
    Instance tmp = {0};
    tmp.cb = *functions;
    tmp.name = (char *)instanceName;
    if (fmuType != fmi2CoSimulation) {
        logf_(&tmp, fmi2Error, "UavBatteryC supports Co-Simulation only");
        return NULL;
    }
    if (guid == NULL || strcmp(guid, MODEL_GUID) != 0) {
        logf_(&tmp, fmi2Error, "GUID mismatch: got %s, expected %s", guid ? guid : "(null)", MODEL_GUID);
        return NULL;
    }
    Instance *c = calloc(1, sizeof *c);
    if (c == NULL) return NULL;
    c->cb = *functions;
    c->name = strdup(instanceName);
    c->logging_on = loggingOn;
    c->state = S_INSTANTIATED;
    memcpy(c->r, START_REAL, sizeof c->r);
    memcpy(c->iv, START_INT, sizeof c->iv);
    battery_build(&c->bat, c->r, c->iv); /* the pythonfmu shell builds the model in __init__ */
    publish(c);
    return c;
}

void fmi2FreeInstance(fmi2Component comp)
{
    Instance *c = comp;
    if (c == NULL) return;
    free(c->name);
    free(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n, const fmi2String cats[])
{
    (void)n;
    (void)cats;
    if (comp == NULL) return fmi2Error;
    ((Instance *)comp)->logging_on = loggingOn;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop)
{
    (void)tolDef; (void)tol; (void)start; (void)stopDef; (void)stop;
    return comp == NULL ? fmi2Error : fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    if (c == NULL || c->state != S_INSTANTIATED) return fmi2Error;
    c->state = S_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    Instance *c = comp;
    if (c == NULL || c->state != S_INIT) return fmi2Error;
    battery_build(&c->bat, c->r, c->iv); /* with the parameter values set by the master */
    publish(c);
    c->state = S_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp)
{
    Instance *c = comp;
    if (c == NULL) return fmi2Error;
    c->state = S_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp)
{
    Instance *c = comp;
    if (c == NULL) return fmi2Error;
    memcpy(c->r, START_REAL, sizeof c->r);
    memcpy(c->iv, START_INT, sizeof c->iv);
    battery_build(&c->bat, c->r, c->iv);
    publish(c);
    c->state = S_INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t n, fmi2Real value[])
{
    Instance *c = comp;
    if (c == NULL) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_VARS || VAR_TYPE[vr[k]] != 'R') return fail(c, "%s: no Real variable %u", "fmi2GetReal", vr[k]);
        value[k] = c->r[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t n, fmi2Integer value[])
{
    Instance *c = comp;
    if (c == NULL) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_VARS || VAR_TYPE[vr[k]] != 'I')
            return fail(c, "%s: no Integer variable %u", "fmi2GetInteger", vr[k]);
        value[k] = c->iv[vr[k]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[])
{
    (void)value;
    if (comp == NULL) return fmi2Error;
    return n == 0 ? fmi2OK : fail(comp, "%s: no Boolean variable %u", "fmi2GetBoolean", vr[0]);
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t n, fmi2String value[])
{
    (void)value;
    if (comp == NULL) return fmi2Error;
    return n == 0 ? fmi2OK : fail(comp, "%s: no String variable %u", "fmi2GetString", vr[0]);
}

static int settable(Instance *c, fmi2ValueReference vr)
{
    if (VAR_KIND[vr] == 'i') return 1;
    return VAR_KIND[vr] == 'p' && (c->state == S_INSTANTIATED || c->state == S_INIT); /* fixed parameters */
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t n, const fmi2Real value[])
{
    Instance *c = comp;
    if (c == NULL) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_VARS || VAR_TYPE[vr[k]] != 'R') return fail(c, "%s: no Real variable %u", "fmi2SetReal", vr[k]);
        if (!settable(c, vr[k])) return fail(c, "%s: variable %u cannot be set now", "fmi2SetReal", vr[k]);
        c->r[vr[k]] = value[k];
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[])
{
    Instance *c = comp;
    if (c == NULL) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_VARS || VAR_TYPE[vr[k]] != 'I')
            return fail(c, "%s: no Integer variable %u", "fmi2SetInteger", vr[k]);
        if (!settable(c, vr[k])) return fail(c, "%s: variable %u cannot be set now", "fmi2SetInteger", vr[k]);
        c->iv[vr[k]] = value[k];
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t n, const fmi2Boolean value[])
{
    (void)value;
    if (comp == NULL) return fmi2Error;
    return n == 0 ? fmi2OK : fail(comp, "%s: no Boolean variable %u", "fmi2SetBoolean", vr[0]);
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t n, const fmi2String value[])
{
    (void)value;
    if (comp == NULL) return fmi2Error;
    return n == 0 ? fmi2OK : fail(comp, "%s: no String variable %u", "fmi2SetString", vr[0]);
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior)
{
    Instance *c = comp;
    (void)t;
    (void)noSetPrior;
    if (c == NULL || c->state != S_STEP) return fmi2Error;
    battery_step(&c->bat, h, c->r[VR_airspeed], c->r[VR_vz], c->iv[VR_phase]);
    publish(c);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp) { (void)comp; return fmi2Error; }

/* not supported (canGetAndSetFMUstate="false", no directional derivatives, no input derivatives) */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
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
{ (void)c; (void)vr; (void)n; (void)order; (void)value; return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[])
{ (void)c; (void)vr; (void)n; (void)order; (void)value; return fmi2Error; }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v)
{ (void)c; (void)s; (void)v; return fmi2Discard; }

/*
 * The recording benchmark's second stand-in (bench/bench_recording.py --workload 20sim): an FMI 2.0
 * Co-Simulation FMU with the variable make-up of the 20-sim ControlledTemperature cross-check FMU that the issue
 * recorded (its modelDescription.xml, read to learn: 120 variables over 51 Real value references, most of them
 * aliases; 19 parameters; 2 Booleans). A heater whose resistance depends on its temperature is switched on and
 * off around a ramped set-point; the names, equations and numbers here are this file's own, the make-up is the
 * original's: which value references are parameters, which stay constant (ground potentials, the supply),
 * which change at events only (the switch), which follow a ramp, which change every step, and how many variables
 * alias each (build.py's LAYOUT_20SIM lists them). controlled_temperature.c is the harsher first stand-in.
 *
 * Real value references (build.py writes the aliases):
 *   0..17   tunable parameters, 18 a fixed one
 *   19..50  the model's quantities (23 is not a Real: Booleans 23 and 24 are the switch's state)
 * fmi2DoStep performs one explicit Euler step of size h.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define NR 51
enum { CAP = 0, T0, BAND, SLOPE, RAMP_START, RAMP_STOP, OFFSET, R1, R2, RON, ROFF, VT, T_SOURCE, G, R_REF, T_REF,
       ALPHA, U_SUPPLY, Q_INT0,
       V_GROUND = 19, I_GROUND, T, ENERGY, ON = 24, T_SET, V_GROUND1, V_GROUND2, I_SUPPLY, V_R1, I_R1, V_R2, I_R2,
       V_SWITCH, R_SWITCH, V_NODE, T_AMB, DT_COND, Q_COND, V_HEATER, I_HEATER, Q_JOULE, R_HEATER, V_SUPPLY, V_TOP,
       Q_NET, T_SET_OUT, T_ROOM_C, I_SWITCH, Q_INT, Q_NET_DER };

static const double START[19] = {0.1, 298.0, 2.0, 4.16667, 8.0, 16.0, 298.15, 5.0e6, 5.0e6, 1.0e-5, 100000.0, 0.5,
                                 293.15, 0.1, 10.0, 293.15, 0.004, 10.0, 0.0};

typedef struct {
    double r[NR];
    fmi2Boolean state, next_state;      /* Booleans 23 and 24 */
    int initialized;
    fmi2CallbackFunctions cb;
    char *name;
} Model;

/* every quantity from the states (temperature, heat integral, switch state) at time t */
static void evaluate(Model *m, double t)
{
    double *r = m->r;
    const double ramp = t < r[RAMP_START] ? 0.0 : r[SLOPE] * (fmin(t, r[RAMP_STOP]) - r[RAMP_START]);
    r[T_SET] = r[T_SET_OUT] = r[OFFSET] + ramp;
    /* on below the band, off above it, as it was inside */
    const double band = 0.5 * r[BAND];
    m->next_state = r[T] < r[T_SET] - band ? fmi2True : r[T] > r[T_SET] + band ? fmi2False : m->state;
    r[ON] = m->next_state ? 1.0 : 0.0;
    r[R_SWITCH] = r[ON] > r[VT] ? r[RON] : r[ROFF];
    r[R_HEATER] = r[R_REF] * (1.0 + r[ALPHA] * (r[T] - r[T_REF]));
    r[V_GROUND] = r[V_GROUND1] = r[V_GROUND2] = 0.0;
    r[V_SUPPLY] = r[V_TOP] = r[V_R1] = r[U_SUPPLY];
    /* the node between the switch and the heater (R2 to ground beside the heater) */
    const double gs = 1.0 / r[R_SWITCH], gh = 1.0 / r[R_HEATER], g2 = 1.0 / r[R2];
    r[V_NODE] = r[V_HEATER] = r[V_R2] = r[U_SUPPLY] * gs / (gs + gh + g2);
    r[V_SWITCH] = r[U_SUPPLY] - r[V_NODE];
    r[I_SWITCH] = r[V_SWITCH] * gs;
    r[I_HEATER] = r[V_NODE] * gh;
    r[I_R2] = r[V_NODE] * g2;
    r[I_R1] = r[U_SUPPLY] / r[R1];
    r[I_SUPPLY] = r[I_SWITCH] + r[I_R1];
    r[I_GROUND] = -r[I_HEATER];
    r[T_AMB] = r[T_SOURCE];
    r[DT_COND] = r[T_AMB] - r[T];
    r[Q_COND] = r[G] * r[DT_COND];
    r[Q_JOULE] = r[V_HEATER] * r[I_HEATER];
    r[Q_NET] = r[Q_NET_DER] = r[Q_COND] + r[Q_JOULE];
    r[ENERGY] = r[CAP] * r[T];
    r[T_ROOM_C] = r[T] - 273.15;
}

static void reset(Model *m)
{
    memset(m->r, 0, sizeof m->r);
    memcpy(m->r, START, sizeof START);
    m->r[T] = START[T0];
    m->r[Q_INT] = START[Q_INT0];
    m->state = m->next_state = fmi2False;
    m->initialized = 0;
}

#include "fmi2_common.h"

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[])
{
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NR || vr[i] == 23) { log_error(m, "fmi2GetReal: unknown value reference"); return fmi2Error; }
        value[i] = m->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean value[])
{
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] != 23 && vr[i] != 24) { log_error(m, "fmi2GetBoolean: unknown value reference"); return fmi2Error; }
        value[i] = vr[i] == 23 ? m->state : m->next_state;
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[])
{
    Model *m = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] > Q_INT0 || m->initialized) {
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
    m->state = m->next_state;
    r[T] += h * r[Q_NET] / r[CAP];
    r[Q_INT] += h * r[Q_NET];
    evaluate(m, t + h);
    return fmi2OK;
}

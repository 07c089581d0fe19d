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

#define HAS_NO_BOOLEANS
#include "fmi2_common.h"

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

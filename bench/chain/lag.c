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
 * (masters look all of them up when loading). The life cycle and the functions
 * this model does not support (they return fmi2Error) are the recording
 * benchmarks' shared block, bench/fmi2_stubs/fmi2_common.h (build.py passes its
 * folder to the compiler and ships it in sources/ beside this file). No global
 * state: any number of instances.
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
} Model;

/* Start values; the state y is x0 until initialization ends (fmi2SetReal keeps it so when x0 is set). */
static void reset(Model *m)
{
    m->r[VR_T] = 1.0;
    m->r[VR_K] = 1.0;
    m->r[VR_X0] = 1.0;
    m->r[VR_U] = 0.0;
    m->r[VR_Y] = m->r[VR_X0];
    m->initialized = 0;
}

/* y is the state, not a function of the inputs: nothing to evaluate outside doStep. */
static void evaluate(Model *m, double t) { (void)m; (void)t; }

#define HAS_NO_BOOLEANS
#include "fmi2_common.h"

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[])
{
    Model *l = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NV) { log_error(l, "fmi2GetReal: unknown value reference"); return fmi2Error; }
        value[i] = l->r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[])
{
    Model *l = (Model *)c;
    for (size_t i = 0; i < n; i++) {
        fmi2ValueReference r = vr[i];
        if (r == VR_Y || r >= NV || (l->initialized && r != VR_U)) {
            log_error(l, "fmi2SetReal: variable cannot be set now");
            return fmi2Error;
        }
        l->r[r] = value[i];
        if (r == VR_X0) l->r[VR_Y] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior)
{
    (void)t; (void)noSetPrior;
    Model *l = (Model *)c;
    double *r = l->r;
    r[VR_Y] += h * (r[VR_K] * r[VR_U] - r[VR_Y]) / r[VR_T];
    return fmi2OK;
}

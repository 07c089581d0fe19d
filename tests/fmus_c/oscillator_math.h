/*
 * Exact propagation of   m x'' = -K x + f   over a step h with constant f.
 * Used by MassA and MassB so that each FMU solves its own ODE exactly for a
 * zero-order-hold input; the only co-simulation error is then the coupling.
 */
#ifndef COSIM_TEST_OSCILLATOR_MATH_H
#define COSIM_TEST_OSCILLATOR_MATH_H

#include <math.h>

/* returns 0 on success, -1 for unsupported parameters (m <= 0 or K < 0) */
static int osc_propagate(double m, double K, double f, double h, double *x, double *v)
{
    double x0 = *x, v0 = *v;
    if (!(m > 0.0) || K < 0.0) return -1;
    if (K == 0.0) {
        double acc = f / m;
        *x = x0 + v0 * h + 0.5 * acc * h * h;
        *v = v0 + acc * h;
    } else {
        double w = sqrt(K / m);
        double xe = f / K; /* equilibrium for the held force */
        double c = cos(w * h), s = sin(w * h);
        *x = xe + (x0 - xe) * c + (v0 / w) * s;
        *v = -(x0 - xe) * w * s + v0 * c;
    }
    return 0;
}

#endif

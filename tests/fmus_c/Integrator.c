/*
 * Integrator: x' = a x + u, y = x (no direct feedthrough).
 * doStep performs exactly one explicit Euler step  x += h (a x + u)
 * so that co-simulation results follow a closed-form linear recurrence.
 * Used for the FMI 2.0 and the FMI 3.0 builds.
 */
#include "model_api.h"

int model_initialize(ModelData *d)
{
    d->r[VR_y] = d->r[VR_x0];
    return M_OK;
}

void model_calc(ModelData *d) { (void)d; }

int model_do_step(ModelData *d, double t, double h)
{
    (void)t;
    d->r[VR_y] += h * (d->r[VR_a] * d->r[VR_y] + d->r[VR_u]);
    return M_OK;
}

/*
 * MassB: mass m tied to a wall by a spring k and to mass 1 (position x_in)
 * by the coupling spring kc:
 *   m x'' = -k x - kc (x - x_in) = -(k + kc) x + kc x_in
 * Parameters m, k, kc, x0, v0; input x_in; outputs x, v and
 *   F = kc (x - x_in)   (force of the coupling spring on mass 1;
 *                        direct feedthrough from x_in).
 * doStep integrates exactly with x_in held constant over the step.
 */
#include "model_api.h"
#include "oscillator_math.h"

int model_initialize(ModelData *d)
{
    if (!(d->r[VR_m] > 0.0) || d->r[VR_k] + d->r[VR_kc] < 0.0) {
        fw_log(d, M_ERROR, "logStatusError", "MassB: invalid parameters m=%g, k+kc=%g", d->r[VR_m],
               d->r[VR_k] + d->r[VR_kc]);
        return M_ERROR;
    }
    d->r[VR_x] = d->r[VR_x0];
    d->r[VR_v] = d->r[VR_v0];
    return M_OK;
}

void model_calc(ModelData *d) { d->r[VR_F] = d->r[VR_kc] * (d->r[VR_x] - d->r[VR_x_in]); }

int model_do_step(ModelData *d, double t, double h)
{
    double K = d->r[VR_k] + d->r[VR_kc];
    (void)t;
    if (osc_propagate(d->r[VR_m], K, d->r[VR_kc] * d->r[VR_x_in], h, &d->r[VR_x], &d->r[VR_v]) != 0) {
        fw_log(d, M_ERROR, "logStatusError", "MassB: invalid parameters m=%g k+kc=%g", d->r[VR_m], K);
        return M_ERROR;
    }
    return M_OK;
}

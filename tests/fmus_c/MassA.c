/*
 * MassA: mass m tied to a wall by a spring k, driven by the coupling force F.
 *   m x'' = -k x + F
 * Parameters m, k, x0, v0; input F; outputs x, v (no direct feedthrough).
 * doStep integrates exactly with F held constant over the step.
 */
#include "model_api.h"
#include "oscillator_math.h"

int model_initialize(ModelData *d)
{
    if (!(d->r[VR_m] > 0.0) || d->r[VR_k] < 0.0) {
        fw_log(d, M_ERROR, "logStatusError", "MassA: invalid parameters m=%g (must be > 0), k=%g (must be >= 0)",
               d->r[VR_m], d->r[VR_k]);
        return M_ERROR;
    }
    d->r[VR_x] = d->r[VR_x0];
    d->r[VR_v] = d->r[VR_v0];
    return M_OK;
}

void model_calc(ModelData *d) { (void)d; }

int model_do_step(ModelData *d, double t, double h)
{
    (void)t;
    if (osc_propagate(d->r[VR_m], d->r[VR_k], d->r[VR_F], h, &d->r[VR_x], &d->r[VR_v]) != 0) {
        fw_log(d, M_ERROR, "logStatusError", "MassA: invalid parameters m=%g k=%g", d->r[VR_m], d->r[VR_k]);
        return M_ERROR;
    }
    return M_OK;
}

/*
 * Oscillator (Model Exchange): m x'' = -k x + u
 * continuous states x, v (outputs, start values exact), derivatives der_x, der_v.
 */
#include "model_api.h"

int model_initialize(ModelData *d)
{
    if (!(d->r[VR_m] > 0.0)) {
        fw_log(d, M_ERROR, "logStatusError", "Oscillator: m must be > 0 (got %g)", d->r[VR_m]);
        return M_ERROR;
    }
    return M_OK;
}

void model_calc(ModelData *d)
{
    d->r[VR_der_x] = d->r[VR_v];
    d->r[VR_der_v] = (-d->r[VR_k] * d->r[VR_x] + d->r[VR_u]) / d->r[VR_m];
}

int model_do_step(ModelData *d, double t, double h)
{
    (void)t;
    (void)h;
    fw_log(d, M_ERROR, "logStatusError", "Oscillator is a Model Exchange FMU: doStep is not available");
    return M_ERROR;
}

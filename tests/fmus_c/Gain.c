/* Gain: y = k u (direct feedthrough, stateless). */
#include "model_api.h"

int model_initialize(ModelData *d)
{
    (void)d;
    return M_OK;
}

void model_calc(ModelData *d) { d->r[VR_y] = d->r[VR_k] * d->r[VR_u]; }

int model_do_step(ModelData *d, double t, double h)
{
    (void)d;
    (void)t;
    (void)h;
    return M_OK;
}

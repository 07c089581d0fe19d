/*
 * Affine: y = a u + b + c sin(w t), a direct-feedthrough block without state.
 * Two of them in a loop (L1.y -> L2.u, L2.y -> L1.u) make an algebraic loop whose fixed point is known:
 *   y1 = (g1 + a1 g2) / (1 - a1 a2),  y2 = a2 y1 + g2,  with g = b + c sin(w t)
 * (ssp/coupling/README.md). It has a unique fixed point when a1 a2 != 1; fixed-point iteration converges
 * when |a1 a2| < 1.
 */
#include <math.h>

#include "model_api.h"

int model_initialize(ModelData *d)
{
    (void)d;
    return M_OK;
}

void model_calc(ModelData *d)
{
    d->r[VR_y] = d->r[VR_a] * d->r[VR_u] + d->r[VR_b] + d->r[VR_c] * sin(d->r[VR_w] * d->time);
}

int model_do_step(ModelData *d, double t, double h)
{
    (void)d;
    (void)t;
    (void)h;
    return M_OK;
}

/*
 * Affine2: y = A u + b + (c sin(w t), 0), a direct-feedthrough block without state with two inputs and two
 * outputs (A = [[a11, a12], [a21, a22]]). Two of them in a loop (P.y1 -> Q.u1, P.y2 -> Q.u2, Q.y1 -> P.u1,
 * Q.y2 -> P.u2) make an algebraic loop of two coupled values each way, whose fixed point is
 *   y_P = (I - A_P A_Q)^-1 (g_P + A_P g_Q),  y_Q = A_Q y_P + g_Q
 * (ssp/coupling/loop2_exact.py): the loop where the coupling updates differ (fixed point converges when the
 * spectral radius of A_P A_Q is below 1; Aitken's one relaxation factor cannot fit two eigenvalues of different
 * sign; IQN-ILS solves a linear loop of two values in a few iterations).
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
    double u1 = d->r[VR_u1], u2 = d->r[VR_u2];
    d->r[VR_y1] = d->r[VR_a11] * u1 + d->r[VR_a12] * u2 + d->r[VR_b1] + d->r[VR_c] * sin(d->r[VR_w] * d->time);
    d->r[VR_y2] = d->r[VR_a21] * u1 + d->r[VR_a22] * u2 + d->r[VR_b2];
}

int model_do_step(ModelData *d, double t, double h)
{
    (void)d;
    (void)t;
    (void)h;
    return M_OK;
}

/*
 * Ball (FMI 3.0 co-simulation with event mode and early return): a ball falling under gravity g from h0 with
 * initial speed v0, bouncing on the ground h = 0 with the coefficient of restitution e.  Between bounces the
 * flight is integrated exactly (a parabola), so every bounce happens at its exact time, inside a
 * communication step: a state event for the importer to handle.
 *
 * The event iteration takes two passes: the first performs the bounce (v := -e v, bounces + 1, t_bounce :=
 * the time) and asks for another; the second checks max_bounces (> 0: the simulation ends at that bounce).
 * A rebound slower than v_min leaves the ball on the ground (no more events).  importer_updates counts the
 * passes the importer asked for in Event Mode (fmi3UpdateDiscreteStates), so that a test can tell events the
 * importer handled from events the FMU handled itself.
 */
#include <math.h>

#include "model_api.h"

int model_initialize(ModelData *d)
{
    if (!(d->r[VR_g] >= 0.0) || !(d->r[VR_e] >= 0.0 && d->r[VR_e] <= 1.0) || !(d->r[VR_h0] >= 0.0)) {
        fw_log(d, M_ERROR, "logStatusError", "Ball: need g >= 0, 0 <= e <= 1 and h0 >= 0 (got %g, %g, %g)",
               d->r[VR_g], d->r[VR_e], d->r[VR_h0]);
        return M_ERROR;
    }
    if (!d->initialized) {
        d->r[VR_h] = d->r[VR_h0];
        d->r[VR_v] = d->r[VR_v0];
        d->i[VR_bounces] = 0;
        d->i[VR_importer_updates] = 0;
        d->b[VR_on_ground] = 0;
        d->r[VR_t_bounce] = -1.0;
    }
    return M_OK;
}

void model_calc(ModelData *d) { (void)d; }

int model_do_step(ModelData *d, double t, double h)
{
    (void)t;
    (void)h;
    fw_log(d, M_ERROR, "logStatusError", "Ball steps through model_step_to_event (built with FW_EVENT_MODE)");
    return M_ERROR;
}

int model_step_to_event(ModelData *d, double t, double h, double *reached, int *event)
{
    double x = d->r[VR_h], v = d->r[VR_v], g = d->r[VR_g], tau = h;
    *event = 0;
    if (d->b[VR_on_ground]) {
        *reached = t + h;
        return M_OK;
    }
    if (g > 0.0) {
        /* the contact: x + v s - g s^2 / 2 = 0, its positive root */
        double disc = v * v + 2.0 * g * x;
        if (disc >= 0.0) {
            double s = (v + sqrt(disc)) / g;
            if (s > 0.0 && s <= h) {
                tau = s;
                *event = 1;
            }
        }
    }
    d->r[VR_h] = *event ? 0.0 : x + v * tau - 0.5 * g * tau * tau;
    d->r[VR_v] = v - g * tau;
    *reached = t + tau;
    return M_OK;
}

int model_update_discrete(ModelData *d, int by_importer, int *again, int *terminate)
{
    *again = 0;
    *terminate = 0;
    if (by_importer) d->i[VR_importer_updates]++;
    if (!d->b[VR_on_ground] && d->r[VR_h] <= 0.0 && d->r[VR_v] < 0.0) {
        double rebound = -d->r[VR_e] * d->r[VR_v];
        d->r[VR_h] = 0.0;
        if (rebound < d->r[VR_v_min]) {
            d->r[VR_v] = 0.0;
            d->b[VR_on_ground] = 1;
        } else {
            d->r[VR_v] = rebound;
        }
        d->i[VR_bounces]++;
        d->r[VR_t_bounce] = d->time;
        *again = 1;
        return M_OK;
    }
    if (d->i[VR_max_bounces] > 0 && d->i[VR_bounces] >= d->i[VR_max_bounces]) {
        fw_log(d, M_OK, "logEvents", "Ball: bounce %d of %d: the simulation ends", d->i[VR_bounces],
               d->i[VR_max_bounces]);
        *terminate = 1;
    }
    return M_OK;
}

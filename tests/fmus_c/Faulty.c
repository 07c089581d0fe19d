/*
 * Faulty: output y = time.  The first doStep whose end time exceeds
 * fail_time (t + h > fail_time + 1e-9) misbehaves according to `mode`:
 *   0 -> never fails
 *   1 -> logs an error and returns Error
 *   2 -> logs a message and returns Discard (time is not advanced;
 *        fmi2GetBooleanStatus(fmi2Terminated) then returns true)
 *   3 -> logs a fatal message and crashes the process with abort()
 *   4 -> crashes the process with a segmentation fault (write through a null pointer)
 *   5 -> hangs (never returns from doStep)
 *   6 -> never fails, but every such doStep sleeps 20 ms and logs (at OK) the monotonic clock at its start
 *        and end: "sleep <start> <end>", so that a test can see which doSteps overlapped in time
 */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include "model_api.h"

int model_initialize(ModelData *d)
{
    if (d->i[VR_mode] < 0 || d->i[VR_mode] > 6) {
        fw_log(d, M_ERROR, "logStatusError", "Faulty: mode must be 0..6 (got %d)", d->i[VR_mode]);
        return M_ERROR;
    }
    return M_OK;
}

void model_calc(ModelData *d) { d->r[VR_y] = d->time; }

int model_do_step(ModelData *d, double t, double h)
{
    double fail_time = d->r[VR_fail_time];
    if (t + h > fail_time + 1e-9) {
        switch (d->i[VR_mode]) {
        case 1:
            fw_log(d, M_ERROR, "logStatusError", "Faulty: injected error in doStep(t=%g, h=%g), fail_time=%g", t, h,
                   fail_time);
            return M_ERROR;
        case 2:
            fw_log(d, M_DISCARD, "logStatusDiscard", "Faulty: injected discard in doStep(t=%g, h=%g), fail_time=%g",
                   t, h, fail_time);
            return M_DISCARD;
        case 3:
            fw_log(d, M_FATAL, "logStatusFatal", "Faulty: injected crash (abort) in doStep(t=%g, h=%g)", t, h);
            abort();
        case 4: {
            volatile int *nowhere = NULL;
            *nowhere = 1;
            break;
        }
        case 5:
            /* a model stuck in an endless wait: to the master the same as an endless iteration (the call never
               returns, a signal's Python handler never runs in it: pause() resumes the wait), without spinning a
               core for every second the tests let it hang */
            for (;;) {
                pause();
            }
        case 6: {
            struct timespec a, b, nap = {0, 20000000};
            clock_gettime(CLOCK_MONOTONIC, &a);
            nanosleep(&nap, NULL);
            clock_gettime(CLOCK_MONOTONIC, &b);
            fw_log(d, M_OK, "logAll", "sleep %.9f %.9f", a.tv_sec + 1e-9 * a.tv_nsec, b.tv_sec + 1e-9 * b.tv_nsec);
            break;
        }
        default:
            break;
        }
    }
    return M_OK;
}

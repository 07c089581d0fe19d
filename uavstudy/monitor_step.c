/* The UAV monitor's common step in C (uavstudy/monitor_native.py), an accelerator of the reference step
 * (uavstudy/monitor_step.py) for few UAVs.  It follows AcceleratedStep._few_uav_step (uavstudy/monitor_fast.py)
 * with the broad phase of CollisionDetector.check_few, ZoneDetector.may_enter / clearance and
 * geometry.pair_clearances, on FewUavState's values (copied in and out by NativeStep.push / pull).
 *
 * One call per master step gathers the monitor's hot values out of the master's buffers (the bytes numpy's
 * take gives) and finishes the step itself when the Python path would find nothing: no phase, mission
 * state or photo count changed, and no contact or zone check gets past its cheap filters (the skip bound,
 * then the pairs' swept boxes and the zones' boxes).  Then it does what _few_uav_step does in that case, with
 * the same IEEE operations in the same order (built with -ffp-contract=off: no fused multiply-add; sqrt is
 * correctly rounded in both), and returns MS_DONE, or MS_IDLE for after_step's idle step.  Anything else
 * returns MS_PYTHON before any state but the gathered values is modified, and Python runs its own path. */
#include <math.h>
#include <stdint.h>
#include <string.h>

enum { MS_DONE = 0, MS_PYTHON = 1, MS_IDLE = 2 };
#define MS_MAX 64

typedef struct {
    const char *src;        /* the master's buffer of one base type */
    const int64_t *idx;     /* element indices into it */
    char *out;              /* where they are gathered (the monitor's hot array) */
    char *prev;             /* the bytes gathered by the previous call */
    int64_t count, size;    /* elements, bytes per element */
    int64_t pos_lo, pos_hi; /* elements [pos_lo, pos_hi) are the positions (compared apart) */
} MsGroup;

typedef struct {
    int64_t n;                      /* UAVs */
    MsGroup *groups;
    int64_t n_groups;
    const double *gathered_position;    /* (n, 3) positions at t1, inside a group's out */
    double *p0;                     /* (n, 3) positions at t0 (FleetState.position) */
    const double *removed_position; /* (n, 3) where the removed UAVs were taken out */
    double *pair_clearance;         /* (n, n) FewUavState.pair_clearance (diagonal unused) */
    double *floats;                 /* rows of n, FewUavState's: distance, distance_xy, flight_time, pair_travel,
                                     * zone_travel, zone_clearance, phase */
    int64_t *ints;                  /* rows of n: took_off, removed, zone_misses, idle_flying (a mask) */
    const double *zone_boxes;       /* (n_zones, 4) zone bounding boxes x0, y0, x1, y1 */
    int64_t n_zones;
    int64_t pair_misses;            /* FewUavState.pair_misses */
    int64_t refresh_every;
    double phase_lo, phase_hi;      /* the airborne phases */
    double altitude_threshold;
    double travel_scale;            /* 1 + SKIP_REL */
    double radius;                  /* half the impact diameter */
    double pair_limit;              /* impact diameter + SKIP_MARGIN */
    double margin;                  /* SKIP_MARGIN */
    int64_t idle_next;              /* the next step may be idle (AcceleratedStep.idle_next) */
    int64_t clearance_refreshed;    /* set when this code refreshed the pair clearances */
    double *scratch;                /* 5 n doubles */
} MsState;

enum { R_DISTANCE, R_DISTANCE_XY, R_FLIGHT_TIME, R_PAIR_TRAVEL, R_ZONE_TRAVEL, R_ZONE_CLEARANCE, R_PHASE };
enum { R_TOOK_OFF, R_REMOVED, R_ZONE_MISSES, R_IDLE_FLYING };

static int gather(MsState *s, int *pos_changed)
{
    int other = 0, moved = 0;
    for (int64_t g = 0; g < s->n_groups; g++) {
        MsGroup *G = &s->groups[g];
        const int64_t sz = G->size;
        for (int64_t i = 0; i < G->count; i++)
            memcpy(G->out + i * sz, G->src + G->idx[i] * sz, (size_t)sz);
        if (G->pos_lo < G->pos_hi) {
            if (memcmp(G->out, G->prev, (size_t)(G->pos_lo * sz)) != 0
                || memcmp(G->out + G->pos_hi * sz, G->prev + G->pos_hi * sz, (size_t)((G->count - G->pos_hi) * sz)) != 0)
                other = 1;
            if (memcmp(G->out + G->pos_lo * sz, G->prev + G->pos_lo * sz, (size_t)((G->pos_hi - G->pos_lo) * sz)) != 0)
                moved = 1;
        } else if (memcmp(G->out, G->prev, (size_t)(G->count * sz)) != 0) {
            other = 1;
        }
        memcpy(G->prev, G->out, (size_t)(G->count * sz));
    }
    *pos_changed = moved;
    return other;
}

/* the broad phase of CollisionDetector.check_few: does any pair of the checked UAVs have overlapping swept boxes? */
static int boxes_overlap(const MsState *s, const int64_t *checked, int64_t n_checked, const double *p1)
{
    double box[MS_MAX][6];
    int64_t m = 0;
    const double r = s->radius;
    for (int64_t u = 0; u < n_checked; u++) {
        const double *a = s->p0 + 3 * checked[u], *b = p1 + 3 * checked[u];
        if (!(a[0] == a[0] && a[1] == a[1] && a[2] == a[2] && b[0] == b[0] && b[1] == b[1] && b[2] == b[2]))
            continue;
        for (int c = 0; c < 3; c++) {
            box[m][c] = (a[c] <= b[c] ? a[c] : b[c]) - r;
            box[m][3 + c] = (a[c] >= b[c] ? a[c] : b[c]) + r;
        }
        m++;
    }
    for (int64_t u = 0; u + 1 < m; u++)
        for (int64_t v = u + 1; v < m; v++)
            if (box[u][0] <= box[v][3] && box[v][0] <= box[u][3] && box[u][1] <= box[v][4]
                && box[v][1] <= box[u][4] && box[u][2] <= box[v][5] && box[v][2] <= box[u][5])
                return 1;
    return 0;
}

/* ZoneDetector.may_enter (without its envelope pre-test, which never changes the answer) */
static int may_enter(const MsState *s, double x0, double y0, double x1, double y1)
{
    if (!(x0 == x0 && y0 == y0 && x1 == x1 && y1 == y1))
        return 1;
    double lx = x0 <= x1 ? x0 : x1, hx = x0 <= x1 ? x1 : x0;
    double ly = y0 <= y1 ? y0 : y1, hy = y0 <= y1 ? y1 : y0;
    for (int64_t z = 0; z < s->n_zones; z++) {
        const double *b = s->zone_boxes + 4 * z;
        if (!(hx < b[0] || lx > b[2] || hy < b[1] || ly > b[3]))
            return 1;
    }
    return 0;
}

/* ZoneDetector.clearance */
static double zone_box_clearance(const MsState *s, double x, double y)
{
    if (!(isfinite(x) && isfinite(y)))
        return NAN;
    double best = INFINITY;
    for (int64_t z = 0; z < s->n_zones; z++) {
        const double *b = s->zone_boxes + 4 * z;
        double dx = x < b[0] ? b[0] - x : (x > b[2] ? x - b[2] : 0.0);
        double dy = y < b[1] ? b[1] - y : (y > b[3] ? y - b[3] : 0.0);
        double d = sqrt(dx * dx + dy * dy);
        if (d < best)
            best = d;
    }
    return best - s->margin;
}

static int refresh_due(int64_t misses, int64_t every)
{
    return misses <= 2 || misses % every == 0;
}

int ms_step(MsState *s, double t0, double t1)
{
    const int64_t n = s->n;
    const double dt = t1 - t0;
    double *distance = s->floats + R_DISTANCE * n, *distance_xy = s->floats + R_DISTANCE_XY * n, *flight_time = s->floats + R_FLIGHT_TIME * n;
    double *pair_travel = s->floats + R_PAIR_TRAVEL * n, *zone_travel = s->floats + R_ZONE_TRAVEL * n, *zone_clearance = s->floats + R_ZONE_CLEARANCE * n;
    const double *phase = s->floats + R_PHASE * n;
    int64_t *took_off = s->ints + R_TOOK_OFF * n, *removed = s->ints + R_REMOVED * n;
    int64_t *zone_misses = s->ints + R_ZONE_MISSES * n, *idle_flying = s->ints + R_IDLE_FLYING * n;
    int moved;
    if (n > MS_MAX || gather(s, &moved))
        return MS_PYTHON;           /* a phase, mission state or photo count changed */
    if (s->idle_next && !moved) {        /* after_step's idle step: only the airborne time goes on */
        for (int64_t k = 0; k < n; k++)
            if (idle_flying[k])
                flight_time[k] += dt;
        return MS_IDLE;
    }
    double *p1 = s->scratch, *length = p1 + 3 * n, *length_xy = length + n;
    int64_t checked[MS_MAX], n_checked = 0;
    for (int64_t k = 0; k < n; k++) {
        const double *a = s->p0 + 3 * k;
        const double *b = removed[k] ? s->removed_position + 3 * k : s->gathered_position + 3 * k;
        p1[3 * k] = b[0];
        p1[3 * k + 1] = b[1];
        p1[3 * k + 2] = b[2];
        double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
        double sxy = dx * dx + dy * dy;
        length[k] = sqrt(sxy + dz * dz);
        length_xy[k] = sqrt(sxy);
        double phase_k = phase[k];
        if (!removed[k] && s->phase_lo <= phase_k && phase_k <= s->phase_hi) {
            double z0 = a[2], z1 = b[2];
            if ((z0 > s->altitude_threshold || z1 > s->altitude_threshold) && z0 == z0 && z1 == z1)
                checked[n_checked++] = k;
        }
    }
    /* the skip tests on the travel including this step; where one fails, the exact check's own filters
     * must reject everything, else it is Python's step (the narrow phase, shapely) */
    int pairs_apart = 1;
    if (n_checked >= 2) {
        for (int64_t u = 0; u + 1 < n_checked && pairs_apart; u++) {
            int64_t i = checked[u];
            double ti = pair_travel[i] + length[i];
            const double *ci = s->pair_clearance + i * n;
            for (int64_t v = u + 1; v < n_checked; v++) {
                int64_t j = checked[v];
                if (!(ci[j] - (ti + (pair_travel[j] + length[j])) * s->travel_scale > 0.0)) {
                    pairs_apart = 0;
                    break;
                }
            }
        }
        if (!pairs_apart && boxes_overlap(s, checked, n_checked, p1))
            return MS_PYTHON;
    }
    char zone_near[MS_MAX];         /* per checked UAV: its zone skip test failed */
    if (s->n_zones)
        for (int64_t u = 0; u < n_checked; u++) {
            int64_t k = checked[u];
            zone_near[u] = !(zone_clearance[k] - (zone_travel[k] + length[k]) * s->travel_scale > 0.0);
            if (zone_near[u] && may_enter(s, s->p0[3 * k], s->p0[3 * k + 1], p1[3 * k], p1[3 * k + 1]))
                return MS_PYTHON;
        }
    /* nothing found: the step's sums and flags as _few_uav_step sets them */
    int64_t n_next = 0;
    int finite = 1;
    for (int64_t k = 0; k < n; k++) {
        pair_travel[k] += length[k];
        zone_travel[k] += length[k];
        double share = removed[k] ? 0.0 : 1.0;   /* a removed UAV adds +0.0, as in Python */
        distance[k] += share * length[k];
        distance_xy[k] += share * length_xy[k];
        double phase_k = phase[k];
        idle_flying[k] = 0;
        if (s->phase_lo <= phase_k && phase_k <= s->phase_hi) {
            flight_time[k] += share * dt;
            if (!removed[k]) {
                took_off[k] = 1;
                idle_flying[k] = 1;
                if (p1[3 * k + 2] > s->altitude_threshold)
                    n_next++;
            }
        }
        for (int c = 0; c < 3; c++) {
            s->p0[3 * k + c] = p1[3 * k + c];
            if (!isfinite(p1[3 * k + c]))
                finite = 0;
        }
    }
    int refresh_pairs = 0;
    if (n_checked >= 2) {
        if (pairs_apart) {
            s->pair_misses = 0;
        } else {
            s->pair_misses++;
            refresh_pairs = refresh_due(s->pair_misses, s->refresh_every);
        }
    }
    if (s->n_zones)
        for (int64_t u = 0; u < n_checked; u++) {
            int64_t k = checked[u];
            if (!zone_near[u]) {
                zone_misses[k] = 0;
            } else if (refresh_due(++zone_misses[k], s->refresh_every)) {
                zone_clearance[k] = zone_box_clearance(s, p1[3 * k], p1[3 * k + 1]);
                zone_travel[k] = 0.0;
            }
        }
    if (refresh_pairs) {            /* geometry.pair_clearances at the new positions */
        for (int64_t i = 0; i + 1 < n; i++)
            for (int64_t j = i + 1; j < n; j++) {
                double dx = p1[3 * j] - p1[3 * i], dy = p1[3 * j + 1] - p1[3 * i + 1];
                double dz = p1[3 * j + 2] - p1[3 * i + 2];
                s->pair_clearance[i * n + j] = s->pair_clearance[j * n + i] = sqrt(dx * dx + dy * dy + dz * dz) - s->pair_limit;
            }
        for (int64_t k = 0; k < n; k++)
            pair_travel[k] = 0.0;
        s->clearance_refreshed = 1;
    }
    s->idle_next = !(n_next >= 2 || (n_next && s->n_zones)) && finite;
    return MS_DONE;
}

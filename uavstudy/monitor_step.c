/* The UAV monitor's common step in C (uavstudy/monitor_native.py; the Python twin is UavMonitor._step_small
 * with CollisionDetector._pairs_few, ZoneDetector.may_enter / clearance and geometry.pair_clearances).
 *
 * One call per master step gathers the monitor's hot values out of the master's buffers (the bytes numpy's
 * take gives) and finishes the step itself when the Python path would find nothing: no phase, mission
 * state or photo count changed, and no contact or zone check gets past its cheap filters (the skip bound,
 * then the pairs' swept boxes and the zones' boxes).  Then it does what _step_small does in that case, with
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
    int64_t n;
    MsGroup *groups;
    int64_t n_groups;
    const double *pos;      /* (n, 3) positions at t1 inside a group's out */
    double *p0;             /* (n, 3) positions at t0 */
    const double *rm_pos;   /* (n, 3) where the removed UAVs were taken out */
    double *clear;          /* (n, n) pair clearances (diagonal unused) */
    double *F;              /* rows of n: dist, dist_xy, ftime, trav, ztrav, zclear, phase */
    int64_t *I;             /* rows of n: took_off, removed, zfails, idle_fly */
    const double *zbox;     /* (n_zones, 4) zone bounding boxes x0, y0, x1, y1 */
    int64_t n_zones;
    int64_t fails;
    int64_t refresh_every;
    double lo, hi, thr, grow, radius, lim, margin;
    int64_t idle;           /* the next step may be idle (UavMonitor._idle) */
    int64_t clear_changed;  /* set when this code refreshed the pair clearances */
    double *scratch;        /* 5 n doubles */
} MsState;

enum { R_DIST, R_DIST_XY, R_FTIME, R_TRAV, R_ZTRAV, R_ZCLEAR, R_PHASE };
enum { R_TOOK_OFF, R_REMOVED, R_ZFAILS, R_IDLE_FLY };

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

/* CollisionDetector._pairs_few: does any pair of the checked UAVs have overlapping swept boxes? */
static int boxes_overlap(const MsState *s, const int64_t *checked, int64_t nchk, const double *p1)
{
    double box[MS_MAX][6];
    int64_t m = 0;
    const double r = s->radius;
    for (int64_t u = 0; u < nchk; u++) {
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
        const double *b = s->zbox + 4 * z;
        if (!(hx < b[0] || lx > b[2] || hy < b[1] || ly > b[3]))
            return 1;
    }
    return 0;
}

/* ZoneDetector.clearance */
static double zone_clearance(const MsState *s, double x, double y)
{
    if (!(isfinite(x) && isfinite(y)))
        return NAN;
    double best = INFINITY;
    for (int64_t z = 0; z < s->n_zones; z++) {
        const double *b = s->zbox + 4 * z;
        double dx = x < b[0] ? b[0] - x : (x > b[2] ? x - b[2] : 0.0);
        double dy = y < b[1] ? b[1] - y : (y > b[3] ? y - b[3] : 0.0);
        double d = sqrt(dx * dx + dy * dy);
        if (d < best)
            best = d;
    }
    return best - s->margin;
}

static int refresh_due(int64_t fails, int64_t every)
{
    return fails <= 2 || fails % every == 0;
}

int ms_step(MsState *s, double t0, double t1)
{
    const int64_t n = s->n;
    const double dt = t1 - t0;
    double *dist = s->F + R_DIST * n, *dist_xy = s->F + R_DIST_XY * n, *ftime = s->F + R_FTIME * n;
    double *trav = s->F + R_TRAV * n, *ztrav = s->F + R_ZTRAV * n, *zclear = s->F + R_ZCLEAR * n;
    const double *ph = s->F + R_PHASE * n;
    int64_t *took_off = s->I + R_TOOK_OFF * n, *removed = s->I + R_REMOVED * n;
    int64_t *zfails = s->I + R_ZFAILS * n, *idle_fly = s->I + R_IDLE_FLY * n;
    int moved;
    if (n > MS_MAX || gather(s, &moved))
        return MS_PYTHON;           /* a phase, mission state or photo count changed */
    if (s->idle && !moved) {        /* after_step's idle step: only the airborne time goes on */
        for (int64_t k = 0; k < n; k++)
            if (idle_fly[k])
                ftime[k] += dt;
        return MS_IDLE;
    }
    double *p1 = s->scratch, *len = p1 + 3 * n, *lxy = len + n;
    int64_t checked[MS_MAX], nchk = 0;
    for (int64_t k = 0; k < n; k++) {
        const double *a = s->p0 + 3 * k;
        const double *b = removed[k] ? s->rm_pos + 3 * k : s->pos + 3 * k;
        p1[3 * k] = b[0];
        p1[3 * k + 1] = b[1];
        p1[3 * k + 2] = b[2];
        double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
        double sxy = dx * dx + dy * dy;
        len[k] = sqrt(sxy + dz * dz);
        lxy[k] = sqrt(sxy);
        double g = ph[k];
        if (!removed[k] && s->lo <= g && g <= s->hi) {
            double z0 = a[2], z1 = b[2];
            if ((z0 > s->thr || z1 > s->thr) && z0 == z0 && z1 == z1)
                checked[nchk++] = k;
        }
    }
    /* the skip tests on the travel including this step; where one fails, the exact check's own filters
     * must reject everything, else it is Python's step (the narrow phase, shapely) */
    int pairs_far = 1;
    if (nchk >= 2) {
        for (int64_t u = 0; u + 1 < nchk && pairs_far; u++) {
            int64_t i = checked[u];
            double ti = trav[i] + len[i];
            const double *ci = s->clear + i * n;
            for (int64_t v = u + 1; v < nchk; v++) {
                int64_t j = checked[v];
                if (!(ci[j] - (ti + (trav[j] + len[j])) * s->grow > 0.0)) {
                    pairs_far = 0;
                    break;
                }
            }
        }
        if (!pairs_far && boxes_overlap(s, checked, nchk, p1))
            return MS_PYTHON;
    }
    char zone_near[MS_MAX];         /* per checked UAV: its zone skip test failed */
    if (s->n_zones)
        for (int64_t u = 0; u < nchk; u++) {
            int64_t k = checked[u];
            zone_near[u] = !(zclear[k] - (ztrav[k] + len[k]) * s->grow > 0.0);
            if (zone_near[u] && may_enter(s, s->p0[3 * k], s->p0[3 * k + 1], p1[3 * k], p1[3 * k + 1]))
                return MS_PYTHON;
        }
    /* nothing found: the step's sums and flags as _step_small sets them */
    int64_t n_next = 0;
    int finite = 1;
    for (int64_t k = 0; k < n; k++) {
        trav[k] += len[k];
        ztrav[k] += len[k];
        double f = removed[k] ? 0.0 : 1.0;
        dist[k] += f * len[k];
        dist_xy[k] += f * lxy[k];
        double g = ph[k];
        idle_fly[k] = 0;
        if (s->lo <= g && g <= s->hi) {
            ftime[k] += f * dt;
            if (!removed[k]) {
                took_off[k] = 1;
                idle_fly[k] = 1;
                if (p1[3 * k + 2] > s->thr)
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
    if (nchk >= 2) {
        if (pairs_far) {
            s->fails = 0;
        } else {
            s->fails++;
            refresh_pairs = refresh_due(s->fails, s->refresh_every);
        }
    }
    if (s->n_zones)
        for (int64_t u = 0; u < nchk; u++) {
            int64_t k = checked[u];
            if (!zone_near[u]) {
                zfails[k] = 0;
            } else if (refresh_due(++zfails[k], s->refresh_every)) {
                zclear[k] = zone_clearance(s, p1[3 * k], p1[3 * k + 1]);
                ztrav[k] = 0.0;
            }
        }
    if (refresh_pairs) {            /* geometry.pair_clearances at the new positions */
        for (int64_t i = 0; i + 1 < n; i++)
            for (int64_t j = i + 1; j < n; j++) {
                double dx = p1[3 * j] - p1[3 * i], dy = p1[3 * j + 1] - p1[3 * i + 1];
                double dz = p1[3 * j + 2] - p1[3 * i + 2];
                s->clear[i * n + j] = s->clear[j * n + i] = sqrt(dx * dx + dy * dy + dz * dz) - s->lim;
            }
        for (int64_t k = 0; k < n; k++)
            trav[k] = 0.0;
        s->clear_changed = 1;
    }
    s->idle = !(n_next >= 2 || (n_next && s->n_zones)) && finite;
    return MS_DONE;
}

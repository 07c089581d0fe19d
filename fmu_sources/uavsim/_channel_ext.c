/* The UavChannel FMU's step in C: the accelerator of Channel.advance (uavsim/channel.py), declared in
 * uavsim/accelerators.py (``uavsim.channel-step``) and checked against it, bit for bit, by the accelerator harness
 * (tests/accelerators/).  A 4-UAV fleet's channel step is a few dozen numbers; in Python most of its time went to
 * calls (numpy's on 4x4 arrays, a dict per broadcast, a line-of-sight test per pair).
 *
 * advance(channel, t, h, variables, names) does what Channel.advance(t, h, positions, clocks, broadcast) does, on
 * the same state, and returns the same (None, or per receiver the list of message tuples):
 *
 * - channel: the Channel; it reads its configuration (n, k, range, latency, loss, EPS, zones, zone_records, and
 *   p.mode, p.period, p.seed, p.near_miss) and reads and writes its public state: last_clock, close_pairs,
 *   in_flight, counters, uav_counters;
 * - variables: the FMU's variables (the shell's variable values) and names[i]: UAV i's broadcast variables in
 *   BROADCAST_REAL + BROADCAST_INT order (x, y, z, vx, vy, wx, wy, clock, state, target, claims0, claims1,
 *   visited0, visited1).
 *
 * It returns NotImplemented, having changed nothing, where the Python step must run: a fleet above MAX_N, a
 * position that is not a finite float (or a subclass of float), a broadcast value that float() or int() refuses.
 *
 * Rounding: a distance is sqrt((dx*dx + dy*dy) + dz*dz) as the reference writes it (and numpy summed it before),
 * built with -ffp-contract=off; the loss draws are SplitMix64 on unsigned 64-bit integers, as the reference's.
 * Line of sight: ZoneMap.blocked (shapely, each zone's interior shrunk by 1e-6 m) is not reimplemented.  A pair is
 * decided here only where the answer cannot depend on rounding or on that shrinking: the segment keeps MARGIN
 * from every zone's boundary (then it is wholly inside, blocked, or wholly outside, clear), or it has a point
 * inside a zone at least MARGIN from its boundary (blocked).  Every other pair is handed to ZoneMap.blocked.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_N 64            /* uavsim.channel.MAX_FLEET */
#define N_FIELDS 14         /* BROADCAST_REAL + BROADCAST_INT */
#define N_REAL 8
#define F_CLOCK 7
#define MARGIN 1e-3         /* m: far above the rounding of the geometry and the zones' 1e-6 m shrinking */

static PyObject *s_n, *s_k, *s_p, *s_range, *s_latency, *s_loss, *s_EPS, *s_zones, *s_zone_records, *s_counters,
    *s_uav_counters, *s_last_clock, *s_close_pairs, *s_in_flight, *s_mode, *s_period, *s_seed, *s_near_miss,
    *s_sent, *s_received, *s_lost, *s_out_of_range, *s_blocked, *s_overflow, *s_near_misses;

static struct { PyObject **key; const char *name; } names_[] = {
    {&s_n, "n"}, {&s_k, "k"}, {&s_p, "p"}, {&s_range, "range"}, {&s_latency, "latency"}, {&s_loss, "loss"},
    {&s_EPS, "EPS"}, {&s_zones, "zones"}, {&s_zone_records, "zone_records"}, {&s_counters, "counters"},
    {&s_uav_counters, "uav_counters"}, {&s_last_clock, "last_clock"}, {&s_close_pairs, "close_pairs"},
    {&s_in_flight, "in_flight"}, {&s_mode, "mode"}, {&s_period, "period"}, {&s_seed, "seed"},
    {&s_near_miss, "near_miss"}, {&s_sent, "sent"}, {&s_received, "received"}, {&s_lost, "lost"},
    {&s_out_of_range, "out_of_range"}, {&s_blocked, "blocked"}, {&s_overflow, "overflow"},
    {&s_near_misses, "near_misses"}};

/* ------------------------------------------------------------------ small helpers */

static int get_double(PyObject *obj, PyObject *name, double *out)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    if (v == NULL) return -1;
    *out = PyFloat_AsDouble(v);
    Py_DECREF(v);
    return (*out == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

static int get_long(PyObject *obj, PyObject *name, long *out)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    if (v == NULL) return -1;
    *out = PyLong_AsLong(v);
    Py_DECREF(v);
    return (*out == -1 && PyErr_Occurred()) ? -1 : 0;
}

/* container[key] += add (a dict and a key, or a list and an index as a Python int) */
static int add_to(PyObject *container, PyObject *key, long long add)
{
    PyObject *old = PyObject_GetItem(container, key), *inc, *sum;
    int rc;
    if (old == NULL) return -1;
    inc = PyLong_FromLongLong(add);
    sum = inc ? PyNumber_Add(old, inc) : NULL;
    Py_DECREF(old);
    Py_XDECREF(inc);
    if (sum == NULL) return -1;
    rc = PyObject_SetItem(container, key, sum);
    Py_DECREF(sum);
    return rc;
}

static int add_at(PyObject *list, long i, long long add)
{
    PyObject *key = PyLong_FromLong(i);
    int rc;
    if (key == NULL) return -1;
    rc = add_to(list, key, add);
    Py_DECREF(key);
    return rc;
}

static int add_uav(PyObject *uav_counters, PyObject *name, long i, long long add)
{
    PyObject *list = PyObject_GetItem(uav_counters, name);
    int rc;
    if (list == NULL) return -1;
    rc = add_at(list, i, add);
    Py_DECREF(list);
    return rc;
}

/* ------------------------------------------------------------------ loss draws (channel.uniform) */

#define GOLDEN 0x9E3779B97F4A7C15ULL

static uint64_t finalize(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

static uint64_t draw_key(uint64_t seed, int64_t number)
{
    uint64_t key = finalize(seed * GOLDEN + 0x632BE59BD9B4E019ULL);
    return finalize(key ^ ((uint64_t)number * GOLDEN));
}

static double uniform(uint64_t key, uint64_t sender, uint64_t receiver)
{
    uint64_t z = finalize(sender * GOLDEN ^ key);
    z = finalize(z ^ (receiver * 0xD1B54A32D192ED03ULL + GOLDEN));
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

/* ------------------------------------------------------------------ line of sight */

static double point_segment(double px, double py, double ax, double ay, double bx, double by)
{
    double dx = bx - ax, dy = by - ay, dd = dx * dx + dy * dy, u;
    if (dd <= 0.0) return sqrt((px - ax) * (px - ax) + (py - ay) * (py - ay));
    u = ((px - ax) * dx + (py - ay) * dy) / dd;
    u = u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u);
    dx = px - ax - u * dx;
    dy = py - ay - u * dy;
    return sqrt(dx * dx + dy * dy);
}

static double cross(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

/* even-odd rule over every ring's edges; only asked of points well clear of the boundary */
static int inside(double px, double py, const double *e, long ne)
{
    int in = 0;
    long q;
    for (q = 0; q < ne; q++, e += 4)
        if ((e[1] > py) != (e[3] > py) && px < e[0] + (py - e[1]) * (e[2] - e[0]) / (e[3] - e[1])) in = !in;
    return in;
}

static double boundary_distance(double px, double py, const double *e, long ne)
{
    double best = INFINITY, d;
    long q;
    for (q = 0; q < ne; q++, e += 4)
        if ((d = point_segment(px, py, e[0], e[1], e[2], e[3])) < best) best = d;
    return best;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* 1: the segment a-b certainly crosses this zone's interior; 0: certainly not; -1: too close to tell here */
static int zone_blocks(double ax, double ay, double bx, double by, const double *e, long ne, double *ts)
{
    double sx = bx - ax, sy = by - ay, dmin = INFINITY, d;
    long q, nt = 0;
    const double *f = e;
    for (q = 0; q < ne; q++, f += 4) {
        double ex = f[2] - f[0], ey = f[3] - f[1];
        double o1 = cross(sx, sy, f[0] - ax, f[1] - ay), o2 = cross(sx, sy, f[2] - ax, f[3] - ay);
        double o3 = cross(ex, ey, ax - f[0], ay - f[1]), o4 = cross(ex, ey, bx - f[0], by - f[1]);
        if (((o1 < 0.0 && o2 > 0.0) || (o1 > 0.0 && o2 < 0.0)) && ((o3 < 0.0 && o4 > 0.0) || (o3 > 0.0 && o4 < 0.0))) {
            dmin = 0.0;
            ts[nt++] = cross(f[0] - ax, f[1] - ay, ex, ey) / cross(sx, sy, ex, ey);
            continue;
        }
        d = point_segment(f[0], f[1], ax, ay, bx, by);
        if (d < dmin) dmin = d;
        d = point_segment(f[2], f[3], ax, ay, bx, by);
        if (d < dmin) dmin = d;
        d = point_segment(ax, ay, f[0], f[1], f[2], f[3]);
        if (d < dmin) dmin = d;
        d = point_segment(bx, by, f[0], f[1], f[2], f[3]);
        if (d < dmin) dmin = d;
    }
    if (dmin > MARGIN)          /* the boundary is not near: wholly inside or wholly outside */
        return inside(0.5 * (ax + bx), 0.5 * (ay + by), e, ne);
    /* a point of the segment deep inside: the midpoints between its crossings of the boundary */
    ts[nt++] = 0.0;
    ts[nt++] = 1.0;
    qsort(ts, (size_t)nt, sizeof(double), cmp_double);
    for (q = 0; q + 1 < nt; q++) {
        double u = 0.5 * (ts[q] + ts[q + 1]), px = ax + u * sx, py = ay + u * sy;
        if (!(u >= 0.0 && u <= 1.0)) continue;
        if (inside(px, py, e, ne) && boundary_distance(px, py, e, ne) > MARGIN) return 1;
    }
    return -1;
}

/* 1 blocked, 0 clear, -1 undecided (the records: per zone its box, edge count, edges; zones_planning.zone_record) */
static int blocked_here(double ax, double ay, double bx, double by, const double *rec, Py_ssize_t len, double *ts)
{
    double lox = ax < bx ? ax : bx, hix = ax < bx ? bx : ax, loy = ay < by ? ay : by, hiy = ay < by ? by : ay;
    Py_ssize_t at = 0;
    int undecided = 0, r;
    while (at + 5 <= len) {
        const double *z = rec + at;
        long ne = (long)z[4];
        at += 5 + (ne > 0 ? 4 * ne : 0);
        if (hix < z[0] - MARGIN || lox > z[2] + MARGIN || hiy < z[1] - MARGIN || loy > z[3] + MARGIN) continue;
        if (ne < 0) { undecided = 1; continue; }
        if (ne == 0) continue;
        r = zone_blocks(ax, ay, bx, by, z + 5, ne, ts);
        if (r == 1) return 1;
        if (r < 0) undecided = 1;
    }
    return undecided ? -1 : 0;
}

/* ------------------------------------------------------------------ the step */

struct uav {
    double x, y, z;
    PyObject *clock;                /* borrowed from variables */
    int alive;
    double real[N_REAL];            /* the broadcast, read at a sending instant */
    PyObject *ints[N_FIELDS - N_REAL];
};

struct pair { double d; long i, j; };
struct heard { double d; long i, b; PyObject *msg; };

static int cmp_heard(const void *a, const void *b)
{
    const struct heard *p = a, *q = b;
    if (p->d != q->d) return p->d < q->d ? -1 : 1;
    if (p->i != q->i) return p->i < q->i ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

struct ctx {
    PyObject *ch, *counters, *uav_counters, *zones;
    long n, k;
    double range, latency, loss, eps, period, near_miss;
    uint64_t seed;
    int none;
    double *records;
    Py_ssize_t n_records;
    struct uav u[MAX_N];
};

static void release_ints(struct ctx *c)
{
    long i;
    int f;
    for (i = 0; i < c->n; i++)
        for (f = 0; f < N_FIELDS - N_REAL; f++) Py_CLEAR(c->u[i].ints[f]);
}

static int near_misses(struct ctx *c)
{
    long order[MAX_N], m = 0, a, b, i, j, fresh = 0;
    double lim = c->near_miss, lim2 = lim * lim;
    PyObject *old = PyObject_GetAttr(c->ch, s_close_pairs), *close = PySet_New(NULL);
    int rc = -1;
    if (old == NULL || close == NULL) goto done;
    for (i = 0; i < c->n; i++)
        if (c->u[i].alive) order[m++] = i;
    for (a = 1; a < m; a++) {       /* sorted by (x, index), as the reference's sweep */
        long v = order[a];
        for (b = a; b > 0 && (c->u[order[b - 1]].x > c->u[v].x ||
                              (c->u[order[b - 1]].x == c->u[v].x && order[b - 1] > v)); b--)
            order[b] = order[b - 1];
        order[b] = v;
    }
    for (a = 0; a < m; a++) {
        i = order[a];
        for (b = a + 1; b < m; b++) {
            double dx, dy, dz;
            j = order[b];
            if (c->u[j].x - c->u[i].x > lim) break;
            dx = c->u[j].x - c->u[i].x;
            dy = c->u[j].y - c->u[i].y;
            dz = c->u[j].z - c->u[i].z;
            if (dx * dx + dy * dy + dz * dz <= lim2) {
                PyObject *key = Py_BuildValue("(ll)", i < j ? i : j, i < j ? j : i);
                int known;
                if (key == NULL || PySet_Add(close, key) < 0) { Py_XDECREF(key); goto done; }
                known = PySet_Contains(old, key);
                Py_DECREF(key);
                if (known < 0) goto done;
                fresh += !known;
            }
        }
    }
    if (PySet_Size(close) > 0 && add_to(c->counters, s_near_misses, fresh) < 0) goto done;
    rc = PyObject_SetAttr(c->ch, s_close_pairs, close);
done:
    Py_XDECREF(old);
    Py_XDECREF(close);
    return rc;
}

static int line_of_sight(struct ctx *c, struct pair *pairs, long *np_, double *ts)
{
    long q, kept = 0;
    PyObject *blocked_fn = PyObject_GetAttr(c->zones, s_blocked);
    if (blocked_fn == NULL) return -1;
    for (q = 0; q < *np_; q++) {
        struct uav *a = &c->u[pairs[q].i], *b = &c->u[pairs[q].j];
        int r = blocked_here(a->x, a->y, b->x, b->y, c->records, c->n_records, ts);
        if (r < 0) {                /* ZoneMap.blocked decides */
            PyObject *res = PyObject_CallFunction(blocked_fn, "(dd)(dd)", a->x, a->y, b->x, b->y);
            long idx;
            if (res == NULL) { Py_DECREF(blocked_fn); return -1; }
            idx = PyLong_AsLong(res);
            Py_DECREF(res);
            if (idx == -1 && PyErr_Occurred()) { Py_DECREF(blocked_fn); return -1; }
            r = idx >= 0;
        }
        if (!r) pairs[kept++] = pairs[q];
    }
    Py_DECREF(blocked_fn);
    if (add_to(c->counters, s_blocked, *np_ - kept) < 0) return -1;
    *np_ = kept;
    return 0;
}

static int send_one(struct ctx *c, int64_t number, double sent_at, struct pair *pairs, double *ts)
{
    long i, j, np_ = 0, senders = 0, oor = 0, q;
    PyObject *list = NULL, *messages = NULL, *entry = NULL, *flying = NULL;
    int rc = -1;
    for (i = 0; i < c->n; i++)
        if (c->u[i].alive) {
            senders++;
            if (add_uav(c->uav_counters, s_sent, i, 1) < 0) return -1;
        }
    if (add_to(c->counters, s_sent, senders) < 0) return -1;
    if (!senders) return 0;
    for (i = 0; i < c->n; i++) {
        if (!c->u[i].alive) continue;
        for (j = 0; j < c->n; j++) {
            double dx, dy, dz, d;
            if (j == i || !c->u[j].alive) continue;
            dx = c->u[i].x - c->u[j].x;
            dy = c->u[i].y - c->u[j].y;
            dz = c->u[i].z - c->u[j].z;
            d = sqrt((dx * dx + dy * dy) + dz * dz);
            if (d <= c->range) { pairs[np_].d = d; pairs[np_].i = i; pairs[np_].j = j; np_++; }
            else oor++;
        }
    }
    if (add_to(c->counters, s_out_of_range, oor) < 0) return -1;
    if (c->zones != Py_None && line_of_sight(c, pairs, &np_, ts) < 0) return -1;
    if (c->loss > 0.0 && np_) {
        uint64_t key = draw_key(c->seed, number);
        long kept = 0;
        for (q = 0; q < np_; q++) {
            if (uniform(key, (uint64_t)pairs[q].i, (uint64_t)pairs[q].j) < c->loss) {
                if (add_uav(c->uav_counters, s_lost, pairs[q].j, 1) < 0) return -1;
            } else
                pairs[kept++] = pairs[q];
        }
        if (add_to(c->counters, s_lost, np_ - kept) < 0) return -1;
        np_ = kept;
    }
    if (!np_) return 0;
    if ((list = PyList_New(np_)) == NULL || (messages = PyDict_New()) == NULL) goto done;
    for (q = 0; q < np_; q++) {
        PyObject *t = Py_BuildValue("(dll)", pairs[q].d, pairs[q].i, pairs[q].j), *sender;
        if (t == NULL) goto done;
        PyList_SetItem(list, q, t);
        if ((sender = PyLong_FromLong(pairs[q].i)) == NULL) goto done;
        if (!PyDict_GetItem(messages, sender)) {
            struct uav *u = &c->u[pairs[q].i];
            PyObject *m = Py_BuildValue("(ddddddddlOOOOOO)", u->x, u->y, u->z, u->real[3], u->real[4],
                                        u->real[5], u->real[6], sent_at, pairs[q].i, u->ints[0], u->ints[1],
                                        u->ints[2], u->ints[3], u->ints[4], u->ints[5]);
            if (m == NULL || PyDict_SetItem(messages, sender, m) < 0) { Py_XDECREF(m); Py_DECREF(sender); goto done; }
            Py_DECREF(m);
        }
        Py_DECREF(sender);
    }
    if ((entry = Py_BuildValue("(dOO)", sent_at + c->latency, list, messages)) == NULL) goto done;
    if ((flying = PyObject_GetAttr(c->ch, s_in_flight)) == NULL) goto done;
    rc = PyList_Append(flying, entry);
done:
    Py_XDECREF(list);
    Py_XDECREF(messages);
    Py_XDECREF(entry);
    Py_XDECREF(flying);
    return rc;
}

static PyObject *deliver(struct ctx *c, double t, double h)
{
    double end = t + h - c->eps;
    PyObject *flying = PyObject_GetAttr(c->ch, s_in_flight), *arriving = NULL, *out = NULL, *received = NULL;
    Py_ssize_t cut = 0, n_flying, b, total = 0;
    struct heard *all = NULL;
    long counts[MAX_N] = {0}, starts[MAX_N], j, q;
    long long overflow = 0, taken_all = 0;
    if (flying == NULL) return NULL;
    n_flying = PyList_Size(flying);
    while (cut < n_flying) {
        PyObject *arrival = PyTuple_GetItem(PyList_GetItem(flying, cut), 0);
        double a;
        if (arrival == NULL) goto fail;
        a = PyFloat_AsDouble(arrival);
        if (a == -1.0 && PyErr_Occurred()) goto fail;
        if (!(a < end)) break;
        cut++;
    }
    if ((arriving = PyList_GetSlice(flying, 0, cut)) == NULL || PyList_SetSlice(flying, 0, cut, NULL) < 0) goto fail;
    for (b = 0; b < cut; b++)
        total += PyList_Size(PyTuple_GetItem(PyList_GetItem(arriving, b), 1));
    if ((all = malloc(sizeof *all * (size_t)(total ? total : 1))) == NULL) { PyErr_NoMemory(); goto fail; }
    /* per receiver, in one array: counted first, then placed */
    for (b = 0; b < cut; b++) {
        PyObject *pairs = PyTuple_GetItem(PyList_GetItem(arriving, b), 1);
        Py_ssize_t np_ = PyList_Size(pairs), p;
        for (p = 0; p < np_; p++) {
            j = PyLong_AsLong(PyTuple_GetItem(PyList_GetItem(pairs, p), 2));
            if (j < 0 || j >= c->n) { if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "receiver"); goto fail; }
            counts[j]++;
        }
    }
    for (j = 0, q = 0; j < c->n; j++) { starts[j] = q; q += counts[j]; counts[j] = 0; }
    for (b = 0; b < cut; b++) {
        PyObject *e = PyList_GetItem(arriving, b), *pairs = PyTuple_GetItem(e, 1), *messages = PyTuple_GetItem(e, 2);
        Py_ssize_t np_ = PyList_Size(pairs), p;
        for (p = 0; p < np_; p++) {
            PyObject *pr = PyList_GetItem(pairs, p);
            struct heard *hd;
            j = PyLong_AsLong(PyTuple_GetItem(pr, 2));
            hd = &all[starts[j] + counts[j]++];
            hd->d = PyFloat_AsDouble(PyTuple_GetItem(pr, 0));
            hd->i = PyLong_AsLong(PyTuple_GetItem(pr, 1));
            hd->b = (long)b;
            hd->msg = PyDict_GetItem(messages, PyTuple_GetItem(pr, 1));       /* borrowed: arriving holds it */
            if (hd->msg == NULL) { if (!PyErr_Occurred()) PyErr_SetString(PyExc_KeyError, "sender"); goto fail; }
        }
    }
    if (PyErr_Occurred()) goto fail;
    if ((out = PyList_New(c->n)) == NULL) goto fail;
    if ((received = PyObject_GetItem(c->uav_counters, s_received)) == NULL) goto fail;
    for (j = 0; j < c->n; j++) {
        long count = counts[j], taken = count < c->k ? count : c->k;
        PyObject *mine;
        if (!c->u[j].alive) count = taken = 0;      /* a silent receiver: nothing taken, nothing counted */
        if ((mine = PyList_New(taken)) == NULL) goto fail;
        PyList_SetItem(out, j, mine);
        if (!taken) continue;
        qsort(all + starts[j], (size_t)count, sizeof *all, cmp_heard);
        for (q = 0; q < taken; q++) {
            Py_INCREF(all[starts[j] + q].msg);
            PyList_SetItem(mine, q, all[starts[j] + q].msg);
        }
        overflow += count - taken;
        taken_all += taken;
        if (add_at(received, j, taken) < 0) goto fail;
    }
    /* the fleet's totals: the reference adds them receiver by receiver, the same sums */
    if (taken_all && (add_to(c->counters, s_overflow, overflow) < 0 ||
                      add_to(c->counters, s_received, taken_all) < 0))
        goto fail;
    free(all);
    Py_DECREF(flying);
    Py_DECREF(arriving);
    Py_DECREF(received);
    return out;
fail:
    free(all);
    Py_XDECREF(flying);
    Py_XDECREF(arriving);
    Py_XDECREF(out);
    Py_XDECREF(received);
    return NULL;
}

/* the channel's configuration; 1: read, 0: not a channel this step serves (NotImplemented), -1: error */
static int configure(struct ctx *c, PyObject *ch)
{
    PyObject *p = PyObject_GetAttr(ch, s_p), *mode = NULL, *seed = NULL;
    int rc = -1;
    c->ch = ch;
    if (p == NULL) return -1;
    if (get_long(ch, s_n, &c->n) < 0 || get_long(ch, s_k, &c->k) < 0 || get_double(ch, s_range, &c->range) < 0 ||
        get_double(ch, s_latency, &c->latency) < 0 || get_double(ch, s_loss, &c->loss) < 0 ||
        get_double(ch, s_EPS, &c->eps) < 0 || get_double(p, s_period, &c->period) < 0 ||
        get_double(p, s_near_miss, &c->near_miss) < 0)
        goto done;
    if ((mode = PyObject_GetAttr(p, s_mode)) == NULL || (seed = PyObject_GetAttr(p, s_seed)) == NULL) goto done;
    if (!PyUnicode_Check(mode) || !PyLong_Check(seed)) { rc = 0; goto done; }
    c->none = PyUnicode_CompareWithASCIIString(mode, "none") == 0;
    c->seed = PyLong_AsUnsignedLongLongMask(seed);
    if (PyErr_Occurred()) goto done;
    rc = c->n >= 1 && c->n <= MAX_N && c->k >= 1;
done:
    Py_DECREF(p);
    Py_XDECREF(mode);
    Py_XDECREF(seed);
    return rc;
}

static PyObject *value(PyObject *variables, PyObject *names, long i, int f)
{
    PyObject *row = PySequence_GetItem(names, i), *name, *v;
    if (row == NULL) return NULL;
    name = PySequence_GetItem(row, f);
    Py_DECREF(row);
    if (name == NULL) return NULL;
    v = PyObject_GetItem(variables, name);      /* new reference */
    Py_DECREF(name);
    return v;
}

/* positions (finite floats, else 0: the Python step runs) and clocks (compared as Python does) */
static int read_state(struct ctx *c, PyObject *variables, PyObject *names)
{
    PyObject *last = PyObject_GetAttr(c->ch, s_last_clock);
    long i;
    int f, rc = -1;
    if (last == NULL) return -1;
    if (!PyList_Check(last) || PyList_Size(last) != c->n) { rc = 0; goto done; }
    for (i = 0; i < c->n; i++) {
        struct uav *u = &c->u[i];
        PyObject *was = PyList_GetItem(last, i);
        double xyz[3];
        for (f = 0; f < 3; f++) {
            PyObject *v = value(variables, names, i, f);
            if (v == NULL) goto done;
            if (!PyFloat_Check(v)) { Py_DECREF(v); rc = 0; goto done; }      /* a float (numpy's too) */
            xyz[f] = PyFloat_AsDouble(v);
            Py_DECREF(v);
            if (!isfinite(xyz[f])) { rc = 0; goto done; }
        }
        u->x = xyz[0]; u->y = xyz[1]; u->z = xyz[2];
        u->clock = value(variables, names, i, F_CLOCK);        /* kept: the new last_clock holds it */
        if (u->clock == NULL) goto done;
        Py_DECREF(u->clock);                                    /* variables keeps it alive during the step */
        if (was == Py_None) { u->alive = 1; continue; }
        if ((u->alive = PyObject_RichCompareBool(u->clock, was, Py_NE)) < 0) goto done;    /* clock != last */
    }
    rc = 1;
done:
    Py_DECREF(last);
    return rc;
}

/* the broadcasts of the living UAVs, as float() and int() make them (0: one refuses, the Python step runs) */
static int read_broadcasts(struct ctx *c, PyObject *variables, PyObject *names)
{
    long i;
    int f;
    for (i = 0; i < c->n; i++) {
        struct uav *u = &c->u[i];
        if (!u->alive) continue;
        for (f = 3; f < N_FIELDS; f++) {
            PyObject *v;
            if (f == F_CLOCK) continue;
            if ((v = value(variables, names, i, f)) == NULL) return -1;
            if (f < N_REAL) {
                u->real[f] = PyFloat_AsDouble(v);
                Py_DECREF(v);
                if (u->real[f] == -1.0 && PyErr_Occurred()) { PyErr_Clear(); return 0; }
            } else {
                u->ints[f - N_REAL] = PyNumber_Long(v);
                Py_DECREF(v);
                if (u->ints[f - N_REAL] == NULL) { PyErr_Clear(); return 0; }
            }
        }
    }
    return 1;
}

static PyObject *advance(PyObject *self, PyObject *args)
{
    PyObject *ch, *variables, *names, *clocks = NULL, *zones = NULL, *records = NULL, *result = NULL, *flying;
    double t, h;
    struct ctx *c;
    struct pair *pairs = NULL;
    double *ts = NULL;
    int ok;
    long i;
    Py_ssize_t r, max_edges = 0;
    (void)self;
    if (!PyArg_ParseTuple(args, "OddOO", &ch, &t, &h, &variables, &names)) return NULL;
    if ((c = calloc(1, sizeof *c)) == NULL) return PyErr_NoMemory();
    if ((ok = configure(c, ch)) <= 0) goto declined;
    if ((ok = read_state(c, variables, names)) <= 0) goto declined;
    {   /* does a broadcast instant fall in [t, t + h)? (Channel.sends_in) */
        int sending = !c->none && ceil((t - c->eps) / c->period) * c->period < t + h - c->eps;
        if (sending && (ok = read_broadcasts(c, variables, names)) <= 0) goto declined;
        if ((zones = PyObject_GetAttr(ch, s_zones)) == NULL) goto error;
        c->zones = zones;
        if (sending && zones != Py_None) {
            Py_ssize_t len;
            if ((records = PyObject_GetAttr(ch, s_zone_records)) == NULL) goto error;
            len = PySequence_Size(records);
            if (len < 0 || (c->records = malloc(sizeof(double) * (size_t)(len ? len : 1))) == NULL) goto error;
            for (r = 0; r < len; r++) {
                PyObject *v = PySequence_GetItem(records, r);
                if (v == NULL) goto error;
                c->records[r] = PyFloat_AsDouble(v);
                Py_DECREF(v);
                if (PyErr_Occurred()) goto error;
            }
            c->n_records = len;
            for (r = 0; r + 5 <= len;) {            /* the most edges of one zone: room for its crossings */
                long ne = (long)c->records[r + 4];
                if (ne > max_edges) max_edges = ne;
                r += 5 + (ne > 0 ? 4 * ne : 0);
            }
        }
        /* the state changes from here on: no more declining */
        if ((clocks = PyList_New(c->n)) == NULL) goto error;
        for (i = 0; i < c->n; i++) {
            Py_INCREF(c->u[i].clock);
            PyList_SetItem(clocks, i, c->u[i].clock);
        }
        if (PyObject_SetAttr(ch, s_last_clock, clocks) < 0) goto error;
        if ((c->counters = PyObject_GetAttr(ch, s_counters)) == NULL ||
            (c->uav_counters = PyObject_GetAttr(ch, s_uav_counters)) == NULL)
            goto error;
        if (near_misses(c) < 0) goto error;
        if (sending) {
            int64_t number = (int64_t)ceil((t - c->eps) / c->period);
            if ((pairs = malloc(sizeof *pairs * (size_t)(c->n * c->n))) == NULL ||
                (ts = malloc(sizeof(double) * (size_t)(max_edges + 2))) == NULL) { PyErr_NoMemory(); goto error; }
            while ((double)number * c->period < t + h - c->eps) {
                if (send_one(c, number, (double)number * c->period, pairs, ts) < 0) goto error;
                number++;
            }
        }
    }
    /* messages fly in the order they arrive: the first is the next to arrive */
    if ((flying = PyObject_GetAttr(ch, s_in_flight)) == NULL) goto error;
    {
        Py_ssize_t nf = PyList_Size(flying);
        double first = 0.0;
        if (nf > 0) first = PyFloat_AsDouble(PyTuple_GetItem(PyList_GetItem(flying, 0), 0));
        Py_DECREF(flying);
        if (PyErr_Occurred()) goto error;
        if (nf == 0 || first >= t + h - c->eps) { Py_INCREF(Py_None); result = Py_None; }
        else result = deliver(c, t, h);
    }
    goto finish;
declined:
    if (ok < 0) goto error;
    Py_INCREF(Py_NotImplemented);
    result = Py_NotImplemented;
    goto finish;
error:
    result = NULL;
finish:
    release_ints(c);
    Py_XDECREF(c->counters);
    Py_XDECREF(c->uav_counters);
    Py_XDECREF(clocks);
    Py_XDECREF(zones);
    Py_XDECREF(records);
    free(c->records);
    free(pairs);
    free(ts);
    free(c);
    return result;
}

static PyMethodDef methods[] = {
    {"advance", advance, METH_VARARGS,
     "advance(channel, t, h, variables, names) -> Channel.advance's result, on the broadcasts held in variables "
     "under names[i]; NotImplemented: nothing done, run the Python step"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_channel_ext", NULL, -1, methods,
                                       NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__channel_ext(void)
{
    size_t i;
    for (i = 0; i < sizeof names_ / sizeof names_[0]; i++)
        if ((*names_[i].key = PyUnicode_InternFromString(names_[i].name)) == NULL) return NULL;
    return PyModule_Create(&moduledef);
}

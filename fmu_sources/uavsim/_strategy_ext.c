/* Fast path of the UavStrategy FMU's step (fmu_sources/UavStrategy.py, uavsim/strategy.py: Strategy.step).
 *
 * step(shell_dict) handles the steps in which nothing happens -- a UAV en route with no arrival, no battery
 * threshold crossed, no phase change, its planned path unchanged and its look-ahead clear of every zone, or
 * waiting on the ground -- and returns True after doing exactly what Strategy.step and the shell's _publish
 * would do.  Whenever anything else may happen it returns False having changed nothing, and the Python code
 * runs the step as always.  So the C code never decides anything the Python code would decide otherwise:
 *
 * - Python's math.hypot is not libm's hypot (they may differ in the last bit), so a distance is only compared
 *   with a threshold here when it is clear of it by a relative margin (SAFE) that no rounding can cross; a
 *   distance close to its threshold is left to Python.
 * - ZoneMap.blocked is not reimplemented: a segment is declared clear only when it keeps a margin from every
 *   zone polygon (misses_zone), far above the rounding of its computed end point, so that no correct segment
 *   test can call it blocked, whatever its prefilters.
 * - Values the step publishes (setpoint, cmd) are copied from the model's own objects, never recomputed; every
 *   number it reads must be an exact float or int (anything else: declined).
 *
 * The step leaves every model attribute as Python would, including model.cmd and model.sp; it writes the
 * outputs that such a step can change (cmd, sp_x, sp_y, sp_z) and, as the shell's _publish, every other
 * output too (unchanged values, written so the shell's variables equal Strategy.outputs() after any step).
 *
 * Layout of Strategy._fast_consts (bytes of native doubles, built in Strategy.__init__):
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

enum { C_RADIUS, C_LAND, C_RETURN, C_LOOKAHEAD, C_BRAKE, C_CRUISE, C_HOME_X, C_HOME_Y, C_PLANNING, C_NZONES,
       C_ZONES };
/* then one record per zone: its bounding box (xmin, ymin, xmax, ymax), its edge count n (-1: unknown, only the
 * box tells) and n edges (x0, y0, x1, y1) of all its rings */

enum { PREFLIGHT, TAKEOFF, TRANSIT, RETURN_DONE, RETURN_LOW, LAND_BASE, LAND_NOW, LANDED_BASE, LANDED_AWAY,
       RETURN_CMD, LAND_CMD };

/* Two correctly rounded-or-nearly hypot implementations differ by a few ulps (1e-16 relative): a margin of
 * 1e-12 relative decides the same comparison for both, whatever the operands. */
#define SAFE 1e-12

/* outcomes, counted for tests and benchmarks (stats()) */
enum { HANDLED, FB_SHELL, FB_STATE, FB_BATTERY, FB_PHASE, FB_ARRIVAL, FB_LEG, FB_PATH, FB_ZONE, FB_NEAR, FB_TYPE,
       NOUTCOMES };
static const char *outcome_names[NOUTCOMES] = {
    "handled", "shell", "state", "battery", "phase", "arrival", "leg", "path", "zone", "near", "type"};
static unsigned long long counts[NOUTCOMES];
static unsigned long long edge_clears;     /* segments found clear of a zone by its edges (its box overlapped) */

/* interned names: the shell's variables and the model's attributes (the same name where the shell publishes a
 * model attribute as it is) */
static PyObject *k_model, *k_command, *k_command_taken, *k_x, *k_y, *k_vx, *k_vy, *k_phase, *k_consumed, *k_dict,
    *k_state, *k_cmd, *k_sp, *k_consts, *k_current_target, *k_targets, *k_home, *k_path, *k_path_goal,
    *k_braking, *k_brake_point, *k_detour, *k_assigned, *k_visited, *k_photo_count, *k_last_photo_target,
    *k_avoid_count, *k_last_photo_time, *k_last_photo_x, *k_last_photo_y, *k_sp_x, *k_sp_y, *k_sp_z,
    *k_mission_state, *k_targets_assigned, *k_targets_visited, *k_avoiding;

static struct { PyObject **key; const char *name; } names[] = {
    {&k_model, "_model"}, {&k_command, "command"}, {&k_command_taken, "_command_taken"}, {&k_x, "x"},
    {&k_y, "y"}, {&k_vx, "vx"}, {&k_vy, "vy"}, {&k_phase, "phase"}, {&k_consumed, "consumed"},
    {&k_dict, "__dict__"}, {&k_state, "state"}, {&k_cmd, "cmd"}, {&k_sp, "sp"}, {&k_consts, "_fast_consts"},
    {&k_current_target, "current_target"}, {&k_targets, "targets"}, {&k_home, "home"}, {&k_path, "path"},
    {&k_path_goal, "path_goal"}, {&k_braking, "braking"}, {&k_brake_point, "brake_point"},
    {&k_detour, "detour"}, {&k_assigned, "assigned"}, {&k_visited, "visited"},
    {&k_photo_count, "photo_count"}, {&k_last_photo_target, "last_photo_target"},
    {&k_avoid_count, "avoid_count"}, {&k_last_photo_time, "last_photo_time"},
    {&k_last_photo_x, "last_photo_x"}, {&k_last_photo_y, "last_photo_y"}, {&k_sp_x, "sp_x"},
    {&k_sp_y, "sp_y"}, {&k_sp_z, "sp_z"}, {&k_mission_state, "mission_state"},
    {&k_targets_assigned, "targets_assigned"}, {&k_targets_visited, "targets_visited"},
    {&k_avoiding, "avoiding"},
};

/* h > r for Python's hypot as surely as for libm's (False when NaN) */
static int clearly_above(double h, double r) { return h > r + SAFE * (fabs(r) + fabs(h)); }
/* h <= r for Python's hypot as surely as for libm's */
static int clearly_below(double h, double r) { return h < r - SAFE * (fabs(r) + fabs(h)); }

/* A borrowed dict item; NULL when missing (or on an error, which the caller reports) */
static PyObject *item(PyObject *d, PyObject *key) { return PyDict_GetItemWithError(d, key); }

static int get_double(PyObject *d, PyObject *key, double *out)
{
    PyObject *v = item(d, key);
    if (v == NULL || !PyFloat_CheckExact(v))
        return 0;
    *out = PyFloat_AsDouble(v);
    return 1;
}

static int get_long(PyObject *d, PyObject *key, long *out)
{
    PyObject *v = item(d, key);
    if (v == NULL || !PyLong_CheckExact(v))
        return 0;
    int overflow = 0;
    *out = PyLong_AsLongAndOverflow(v, &overflow);
    return !overflow;
}

/* (x, y) of a tuple or list of two floats (Python unpacks it the same) */
static int point(PyObject *p, double *x, double *y)
{
    PyObject *a, *b;
    if (PyTuple_Check(p) && PyTuple_Size(p) == 2) {
        a = PyTuple_GetItem(p, 0);
        b = PyTuple_GetItem(p, 1);
    } else if (PyList_Check(p) && PyList_Size(p) == 2) {
        a = PyList_GetItem(p, 0);
        b = PyList_GetItem(p, 1);
    } else {
        return 0;
    }
    if (!PyFloat_CheckExact(a) || !PyFloat_CheckExact(b))
        return 0;
    *x = PyFloat_AsDouble(a);
    *y = PyFloat_AsDouble(b);
    return 1;
}

/* orientation of r about the line p-q (twice the signed area), and a bound on its rounding error (a few ulps of
 * the products, taken 100 times) */
static double orient(double px, double py, double qx, double qy, double rx, double ry, double *err)
{
    const double a = (qx - px) * (ry - py), b = (qy - py) * (rx - px);
    *err = 1e-14 * (fabs(a) + fabs(b));
    return a - b;
}

/* The segment a-b keeps more than delta from the zone (record: box, edge count, edges), so it cannot touch its
 * interior, nor can a segment whose points lie within delta of it.  Certain or declined (0):
 * - the segment's box widened by delta misses the zone's box; or
 * - every orientation test is decided with room: an edge end farther than delta from the segment's line and a
 *   segment end farther than delta from the edge's line (that is |orient| > delta * length + its rounding,
 *   lengths taken as |dx| + |dy| >= the true ones), so no edge crosses the segment and the segment, whose ends
 *   are then no nearer than delta to any edge, stays farther than delta from the boundary; and a is outside
 *   the zone by the even-odd rule over all its rings (a ray from a, with a farther than delta from every edge,
 *   so the crossing abscissae, exact to a few ulps, are compared with room). */
static int misses_zone(const double *z, double ax, double ay, double bx, double by, double delta)
{
    const double lox = (ax < bx ? ax : bx) - delta, hix = (ax < bx ? bx : ax) + delta;
    const double loy = (ay < by ? ay : by) - delta, hiy = (ay < by ? by : ay) + delta;
    const double lab = fabs(bx - ax) + fabs(by - ay);
    const int n = (int)z[4];
    const double *e = z + 5;
    int inside = 0;
    if (hix < z[0] || lox > z[2] || hiy < z[1] || loy > z[3])
        return 1;
    if (n < 1 || !(lab > 0.0))
        return 0;          /* no edges known, or a point */
    for (int i = 0; i < n; i++, e += 4) {
        const double cx = e[0], cy = e[1], dx = e[2], dy = e[3], lcd = fabs(dx - cx) + fabs(dy - cy);
        double r1, r2, r3, r4;
        const double o1 = orient(ax, ay, bx, by, cx, cy, &r1), o2 = orient(ax, ay, bx, by, dx, dy, &r2);
        const double o3 = orient(cx, cy, dx, dy, ax, ay, &r3), o4 = orient(cx, cy, dx, dy, bx, by, &r4);
        if (!(fabs(o1) > delta * lab + r1 && fabs(o2) > delta * lab + r2 && fabs(o3) > delta * lcd + r3 &&
              fabs(o4) > delta * lcd + r4))
            return 0;
        if ((o1 > 0.0) != (o2 > 0.0) && (o3 > 0.0) != (o4 > 0.0))
            return 0;      /* they cross: blocked, Python's to handle */
        if ((cy > ay) != (dy > ay) && ax < cx + (ay - cy) * (dx - cx) / (dy - cy))
            inside = !inside;
    }
    edge_clears += !inside;
    return !inside;
}

/* No zone can block the segment a-b (nor the segment Python computes, whose computed end lies within a few ulps
 * of b): it keeps a margin from every zone, far above those ulps and far below any distance that matters.
 * (NaN anywhere fails every comparison: not clear.) */
static int clear_of_zones(const double *c, double ax, double ay, double bx, double by)
{
    const double delta = 1e-9 * (1.0 + fabs(ax) + fabs(ay) + fabs(bx) + fabs(by));
    const int n = (int)c[C_NZONES];
    const double *z = c + C_ZONES;
    if (!(delta < INFINITY))
        return 0;
    for (int i = 0; i < n; i++, z += 5 + 4 * (z[4] > 0.0 ? (int)z[4] : 0))
        if (!misses_zone(z, ax, ay, bx, by, delta))
            return 0;
    return 1;
}

struct step_in {
    double x, y, vx, vy;
    const double *c;
    PyObject *model;        /* the model's __dict__ */
};

/* Strategy._planned without a re-plan, a waypoint reached, a brake or a stop: the waypoint object (borrowed),
 * or NULL with *why set.  goal: the leg's goal object. */
static PyObject *planned(const struct step_in *s, PyObject *goal, int *why)
{
    PyObject *m = s->model, *pg = item(m, k_path_goal), *braking, *path, *wp;
    const double x = s->x, y = s->y, vx = s->vx, vy = s->vy, *c = s->c;
    double wx, wy;
    int ne;
    *why = FB_PATH;
    if (pg == NULL)
        return NULL;
    ne = PyObject_RichCompareBool(goal, pg, Py_NE);     /* goal != self.path_goal: a new leg */
    if (ne != 0)
        return NULL;
    const double gs = hypot(vx, vy);
    const int moving = clearly_above(gs, 0.5), still = clearly_below(gs, 0.5);
    if (!moving && !still) {
        *why = FB_NEAR;
        return NULL;
    }
    braking = item(m, k_braking);
    if (braking != Py_False) {
        if (braking == Py_True && moving) {     /* braking on: stay at the brake point */
            PyObject *bp = item(m, k_brake_point);
            if (bp != NULL && point(bp, &wx, &wy)) {
                *why = HANDLED;
                return bp;
            }
        }
        return NULL;
    }
    path = item(m, k_path);
    if (path == NULL || !PyList_CheckExact(path) || PyList_Size(path) < 1)
        return NULL;
    wp = PyList_GetItem(path, 0);
    if (!point(wp, &wx, &wy)) {
        *why = FB_TYPE;
        return NULL;
    }
    const double dw = hypot(wx - x, wy - y);
    if (PyList_Size(path) > 1 && !clearly_above(dw, c[C_RADIUS])) {   /* a waypoint reached (or nearly) */
        *why = FB_ARRIVAL;
        return NULL;
    }
    if (moving) {       /* the safety net's look-ahead along the velocity */
        const double stop = c[C_LOOKAHEAD] + gs * gs / (2.0 * c[C_BRAKE]);
        const double la = stop < dw ? stop : dw;
        if (!(la > 2e-9)) {
            *why = FB_NEAR;
            return NULL;
        }
        if (!clear_of_zones(c, x, y, x + la * vx / gs, y + la * vy / gs)) {
            *why = FB_ZONE;
            return NULL;
        }
    }
    if (!clear_of_zones(c, x, y, wx, wy)) {
        *why = FB_ZONE;
        return NULL;
    }
    *why = HANDLED;
    return wp;
}

/* Strategy._reactive without a detour vertex reached or a detour planned: the waypoint object (borrowed), or
 * NULL with *why set. */
static PyObject *reactive(const struct step_in *s, PyObject *goal, int *why)
{
    PyObject *detour = item(s->model, k_detour);
    const double x = s->x, y = s->y, vx = s->vx, vy = s->vy, *c = s->c, la = c[C_LOOKAHEAD];
    double gx, gy, ux, uy;
    *why = FB_PATH;
    if (detour == NULL || !PyList_CheckExact(detour))
        return NULL;
    if (PyList_Size(detour) == 1)           /* Python drops a lone goal from the detour */
        return NULL;
    if (PyList_Size(detour) > 1) {           /* flying a detour: to its next vertex unless reached or blocked */
        double wx, wy;
        PyObject *wp = PyList_GetItem(detour, 0);
        if (!point(wp, &wx, &wy)) {
            *why = FB_TYPE;
            return NULL;
        }
        if (!clearly_above(hypot(wx - x, wy - y), c[C_RADIUS])) {
            *why = FB_ARRIVAL;
            return NULL;
        }
        if (!clear_of_zones(c, x, y, wx, wy)) {
            *why = FB_ZONE;
            return NULL;
        }
        *why = HANDLED;
        return wp;
    }
    if (!point(goal, &gx, &gy)) {
        *why = FB_TYPE;
        return NULL;
    }
    const double gs = hypot(vx, vy), dx = gx - x, dy = gy - y, dd = hypot(dx, dy);
    *why = FB_NEAR;
    if (clearly_above(gs, 0.5)) {
        ux = vx / gs;
        uy = vy / gs;
    } else if (clearly_below(gs, 0.5)) {
        if (clearly_below(dd, 1e-9)) {       /* on the goal: Python returns it without a test */
            *why = HANDLED;
            return goal;
        }
        if (!clearly_above(dd, 1e-9))
            return NULL;
        ux = dx / dd;
        uy = dy / dd;
    } else {
        return NULL;
    }
    if (!clear_of_zones(c, x, y, x + la * ux, y + la * uy)) {
        *why = FB_ZONE;
        return NULL;
    }
    /* the segment toward the goal (Strategy._towards): the goal itself within la, else la along the way */
    if (clearly_below(dd, la) || clearly_below(dd, 1e-9)) {
        if (!clear_of_zones(c, x, y, gx, gy)) {
            *why = FB_ZONE;
            return NULL;
        }
    } else if (clearly_above(dd, la) && clearly_above(dd, 1e-9)) {
        if (!clear_of_zones(c, x, y, x + la * dx / dd, y + la * dy / dd)) {
            *why = FB_ZONE;
            return NULL;
        }
    } else {
        return NULL;
    }
    *why = HANDLED;
    return goal;
}

/* The new model.sp, (float(wx), float(wy), cruise_altitude): the current tuple when it holds those values
 * already (the common case: the same waypoint as last step); a new reference, or NULL on an error. */
static PyObject *setpoint(PyObject *m, PyObject *wp, double cruise)
{
    PyObject *sp = item(m, k_sp), *a, *b, *z, *out;
    double wx, wy;
    point(wp, &wx, &wy);
    if (sp != NULL && PyTuple_CheckExact(sp) && PyTuple_Size(sp) == 3) {
        PyObject *o0 = PyTuple_GetItem(sp, 0), *o1 = PyTuple_GetItem(sp, 1), *o2 = PyTuple_GetItem(sp, 2);
        if (PyFloat_CheckExact(o0) && PyFloat_CheckExact(o1) && PyFloat_CheckExact(o2)) {
            const double v[3] = {PyFloat_AsDouble(o0), PyFloat_AsDouble(o1), PyFloat_AsDouble(o2)};
            const double w[3] = {wx, wy, cruise};
            if (memcmp(v, w, sizeof v) == 0) {
                Py_INCREF(sp);
                return sp;
            }
        }
    }
    a = PyFloat_FromDouble(wx);
    b = PyFloat_FromDouble(wy);
    z = PyFloat_FromDouble(cruise);
    out = (a && b && z) ? PyTuple_Pack(3, a, b, z) : NULL;
    Py_XDECREF(a);
    Py_XDECREF(b);
    Py_XDECREF(z);
    return out;
}


static PyObject *small_int[4];     /* 0..3: cmd and avoiding values */

/* The model's attributes that _publish reads, checked before anything is written */
struct published {
    PyObject *src[8];                   /* published as they are (keys: out_keys) */
    Py_ssize_t assigned, visited;
    int avoiding;
};

static PyObject **src_keys[8] = {&k_state, &k_photo_count, &k_last_photo_target, &k_current_target,
                                 &k_avoid_count, &k_last_photo_time, &k_last_photo_x, &k_last_photo_y};
static PyObject **out_keys[8] = {&k_mission_state, &k_photo_count, &k_last_photo_target, &k_current_target,
                                 &k_avoid_count, &k_last_photo_time, &k_last_photo_x, &k_last_photo_y};

static int gather(PyObject *m, int planning, struct published *p)
{
    PyObject *assigned = item(m, k_assigned), *visited = item(m, k_visited);
    for (int i = 0; i < 8; i++)
        if ((p->src[i] = item(m, *src_keys[i])) == NULL)
            return 0;
    if (assigned == NULL || visited == NULL || !PyList_CheckExact(assigned) || !PyList_CheckExact(visited))
        return 0;
    p->assigned = PyList_Size(assigned);
    p->visited = PyList_Size(visited);
    if (planning) {       /* Strategy.outputs(): braking or a path with detour vertices */
        PyObject *braking = item(m, k_braking), *path = item(m, k_path);
        if ((braking != Py_True && braking != Py_False) || path == NULL || !PyList_CheckExact(path))
            return 0;
        p->avoiding = braking == Py_True || PyList_Size(path) > 1;
    } else {
        PyObject *detour = item(m, k_detour);
        if (detour == NULL || !PyList_CheckExact(detour))
            return 0;
        p->avoiding = PyList_Size(detour) > 0;
    }
    return 1;
}

static int set_size(PyObject *d, PyObject *key, Py_ssize_t n)
{
    PyObject *v = PyLong_FromSsize_t(n);
    int rc = v == NULL ? -1 : PyDict_SetItem(d, key, v);
    Py_XDECREF(v);
    return rc;
}

/* Strategy.step's effects (model.cmd, model.sp) and the shell's _publish */
static int commit(PyObject *d, PyObject *m, PyObject *cmd, PyObject *sp, const struct published *p)
{
    if (PyDict_SetItem(m, k_cmd, cmd) < 0 || PyDict_SetItem(m, k_sp, sp) < 0)
        return -1;
    if (PyDict_SetItem(d, k_cmd, cmd) < 0 || PyDict_SetItem(d, k_sp_x, PyTuple_GetItem(sp, 0)) < 0 ||
        PyDict_SetItem(d, k_sp_y, PyTuple_GetItem(sp, 1)) < 0 || PyDict_SetItem(d, k_sp_z, PyTuple_GetItem(sp, 2)) < 0 ||
        set_size(d, k_targets_assigned, p->assigned) < 0 || set_size(d, k_targets_visited, p->visited) < 0 ||
        PyDict_SetItem(d, k_avoiding, small_int[p->avoiding]) < 0)
        return -1;
    for (int i = 0; i < 8; i++)
        if (PyDict_SetItem(d, *out_keys[i], p->src[i]) < 0)
            return -1;
    return 0;
}

/* The battery rules of Strategy.step change nothing (phase airborne: below the landing threshold, and below the
 * return threshold unless the state ignores it) */
static int battery_quiet(const double *c, long phase, double consumed, long state)
{
    if (phase < 1 || phase > 3)
        return 1;
    if (consumed >= c[C_LAND])
        return 0;
    return !(consumed >= c[C_RETURN] && (state == TAKEOFF || state == TRANSIT));
}

/* The waypoint of an airborne step without any event (borrowed), or NULL with *why set */
static PyObject *en_route(const struct step_in *s, long state, int *why)
{
    PyObject *m = s->model, *goal;
    const double *c = s->c;
    double gx, gy;
    if (state == TRANSIT) {
        long k;
        PyObject *targets = item(m, k_targets);
        *why = FB_LEG;
        if (!get_long(m, k_current_target, &k) || k < 0 || targets == NULL || !PyList_CheckExact(targets) ||
            k >= PyList_Size(targets))
            return NULL;
        goal = PyList_GetItem(targets, k);
        if (!point(goal, &gx, &gy)) {
            *why = FB_TYPE;
            return NULL;
        }
        if (!clearly_above(hypot(gx - s->x, gy - s->y), c[C_RADIUS])) {     /* a photo (or nearly) */
            *why = FB_ARRIVAL;
            return NULL;
        }
    } else {
        goal = item(m, k_home);
        if (goal == NULL || !point(goal, &gx, &gy)) {
            *why = FB_TYPE;
            return NULL;
        }
        if (!clearly_above(hypot(s->x - gx, s->y - gy), c[C_RADIUS])) {     /* at the base (or nearly) */
            *why = FB_ARRIVAL;
            return NULL;
        }
    }
    if (c[C_NZONES] == 0.0) {
        *why = HANDLED;
        return goal;
    }
    return c[C_PLANNING] != 0.0 ? planned(s, goal, why) : reactive(s, goal, why);
}

static PyObject *step(PyObject *module, PyObject *d)
{
    PyObject *m, *mdict = NULL, *consts, *cmd, *sp = NULL, *wp = NULL, *command, *taken, *result = Py_False;
    struct step_in s;
    struct published pub;
    double consumed;
    long phase, state;
    int why = FB_SHELL, planning;
    (void)module;
    if (!PyDict_Check(d)) {
        PyErr_SetString(PyExc_TypeError, "step(shell.__dict__)");
        return NULL;
    }
    m = item(d, k_model);
    command = item(d, k_command);
    taken = item(d, k_command_taken);
    if (m == NULL || m == Py_None || command == NULL || taken == NULL || command != taken ||
        !get_double(d, k_x, &s.x) || !get_double(d, k_y, &s.y) || !get_double(d, k_vx, &s.vx) ||
        !get_double(d, k_vy, &s.vy) || !get_double(d, k_consumed, &consumed) || !get_long(d, k_phase, &phase))
        goto done;        /* a command to take (ints compare by identity only when small: a new one then) */
    if ((mdict = PyObject_GetAttr(m, k_dict)) == NULL || !PyDict_Check(mdict)) {
        PyErr_Clear();    /* not a Strategy: Python's step says what is wrong */
        goto done;
    }
    s.model = mdict;
    consts = item(mdict, k_consts);
    why = FB_STATE;
    if (consts == NULL || !PyBytes_Check(consts) || PyBytes_Size(consts) < (Py_ssize_t)(C_ZONES * sizeof(double)) ||
        !get_long(mdict, k_state, &state))
        goto done;
    s.c = (const double *)PyBytes_AsString(consts);
    planning = s.c[C_PLANNING] != 0.0;
    switch (state) {
    case LANDED_BASE:
    case LANDED_AWAY:
        cmd = small_int[3];
        break;
    case LAND_BASE:
    case LAND_NOW:
    case LAND_CMD:
        if (phase == 4)
            goto done;          /* touchdown */
        cmd = small_int[3];
        break;
    case PREFLIGHT:
        why = FB_PHASE;
        if (phase == 1 || phase == 2 || (phase == 3 && consumed >= s.c[C_LAND]))
            goto done;
        cmd = small_int[1];
        break;
    case TAKEOFF:
        why = FB_PHASE;
        if (phase == 2)
            goto done;          /* climb done: the first leg starts */
        why = FB_BATTERY;
        if (!battery_quiet(s.c, phase, consumed, state))
            goto done;
        cmd = small_int[1];
        break;
    case TRANSIT:
    case RETURN_DONE:
    case RETURN_LOW:
    case RETURN_CMD:
        why = FB_BATTERY;
        if (!battery_quiet(s.c, phase, consumed, state))
            goto done;
        why = FB_PHASE;
        if (phase == 4)
            goto done;
        if ((wp = en_route(&s, state, &why)) == NULL)
            goto done;
        cmd = small_int[2];
        break;
    default:
        goto done;
    }
    if (wp != NULL)
        sp = setpoint(mdict, wp, s.c[C_CRUISE]);
    else if ((sp = item(mdict, k_sp)) != NULL)
        Py_INCREF(sp);
    if (PyErr_Occurred())
        goto error;
    why = FB_TYPE;
    if (sp == NULL || !PyTuple_CheckExact(sp) || PyTuple_Size(sp) != 3 || !gather(mdict, planning, &pub))
        goto done;
    if (commit(d, mdict, cmd, sp, &pub) < 0)
        goto error;
    why = HANDLED;
    result = Py_True;
done:
    if (PyErr_Occurred())
        goto error;
    counts[why]++;
    Py_XDECREF(sp);
    Py_XDECREF(mdict);
    Py_INCREF(result);
    return result;
error:
    Py_XDECREF(sp);
    Py_XDECREF(mdict);
    return NULL;
}

static PyObject *stats(PyObject *module, PyObject *unused)
{
    PyObject *out = PyDict_New();
    (void)module;
    (void)unused;
    for (int i = 0; out != NULL && i < NOUTCOMES; i++) {
        PyObject *v = PyLong_FromUnsignedLongLong(counts[i]);
        if (v == NULL || PyDict_SetItemString(out, outcome_names[i], v) < 0) {
            Py_XDECREF(v);
            Py_DECREF(out);
            return NULL;
        }
        Py_DECREF(v);
    }
    if (out != NULL) {
        PyObject *v = PyLong_FromUnsignedLongLong(edge_clears);
        if (v == NULL || PyDict_SetItemString(out, "edge_clears", v) < 0) {
            Py_XDECREF(v);
            Py_DECREF(out);
            return NULL;
        }
        Py_DECREF(v);
    }
    return out;
}

static PyObject *reset_stats(PyObject *module, PyObject *unused)
{
    (void)module;
    (void)unused;
    memset(counts, 0, sizeof counts);
    edge_clears = 0;
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"step", step, METH_O,
     "step(shell.__dict__) -> True when the step was done here (model and outputs updated), False when nothing "
     "was changed and Python must run it"},
    {"stats", stats, METH_NOARGS, "counts of the steps done here ('handled'), of each reason to decline, and of the segments found clear of a zone by its edges ('edge_clears')"},
    {"reset_stats", reset_stats, METH_NOARGS, "zero the counts"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module_def = {PyModuleDef_HEAD_INIT, "_strategy_ext",
                                        "Fast path of UavStrategy's step (see _strategy_ext.c)", -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__strategy_ext(void)
{
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if ((*names[i].key = PyUnicode_InternFromString(names[i].name)) == NULL)
            return NULL;
    for (int i = 0; i < 4; i++)
        if ((small_int[i] = PyLong_FromLong(i)) == NULL)
            return NULL;
    return PyModule_Create(&module_def);
}

/* The UavStrategy FMU's step in C: the accelerator of Strategy.step (uavsim/strategy.py), declared in
 * uavsim/strategy_accel.py and checked against it by the accelerator harness (tests/accelerators/).
 *
 * step(constants, mission, variables) handles the steps in which nothing happens -- a UAV en route with no
 * arrival, no battery threshold crossed, no phase change, its planned path unchanged and its look-ahead clear of
 * every zone, or waiting on the ground -- and returns True after doing exactly what Strategy.step and the
 * shell's _publish would do.  Whenever anything else may happen it returns False having changed nothing, and the
 * Python step runs as always.  So the C code never decides anything the Python code would decide otherwise:
 *
 * - Python's math.hypot is not libm's hypot (they may differ in the last bit), so a distance is only compared
 *   with a threshold here when it is clear of it by a relative margin (SAFE) that no rounding can cross; a
 *   distance close to its threshold is left to Python.
 * - ZoneMap.blocked is not reimplemented: a segment is declared clear only when it keeps a margin from every
 *   zone polygon (misses_zone), far above the rounding of its computed end point, so that no correct segment
 *   test can call it blocked, whatever its prefilters.
 * - Values the step publishes (setpoint, cmd) are copied from the mission's own objects, never recomputed; every
 *   number it reads must be an exact float or int (anything else: declined).
 *
 * What it reads and writes, all public:
 * - constants: Strategy.step_constants, the configuration as native doubles (layout C_* below);
 * - mission: the Strategy's MissionState, whose fields it gets and sets by their declared names (field_names);
 *   a missing field is an error (AttributeError), not a reason to decline: a renamed field must not silently
 *   switch this step off;
 * - variables: the FMU's variables by their modelDescription names (the shell's variable values): the inputs
 *   x, y, vx, vy, phase, consumed, command are read, every output (OUTPUT_NAMES of uavsim/strategy.py) is
 *   written, so that they equal Strategy.outputs() after any step.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

/* Layout of Strategy.step_constants (Strategy._pack_step_constants) */
enum { C_RADIUS, C_LAND, C_RETURN, C_LOOKAHEAD, C_BRAKE, C_CRUISE, C_HOME_X, C_HOME_Y, C_PLANNING, C_ASSIGNED,
       C_NTARGETS, C_NZONES, C_TARGETS };
/* then the targets (x, y), then one record per zone (zone_record): its bounding box (xmin, ymin, xmax, ymax), its
 * edge count n (-1: unknown, only the box tells) and n edges (x0, y0, x1, y1) of all its rings */

enum { PREFLIGHT, TAKEOFF, TRANSIT, RETURN_DONE, RETURN_LOW, LAND_BASE, LAND_NOW, LANDED_BASE, LANDED_AWAY,
       RETURN_CMD, LAND_CMD };

/* Two correctly rounded-or-nearly hypot implementations differ by a few ulps (1e-16 relative): a margin of
 * 1e-12 relative decides the same comparison for both, whatever the operands. */
#define SAFE 1e-12

/* outcomes, counted for benchmarks (stats()) */
enum { HANDLED, FB_INPUT, FB_STATE, FB_BATTERY, FB_PHASE, FB_ARRIVAL, FB_LEG, FB_PATH, FB_ZONE, FB_NEAR, FB_TYPE,
       NOUTCOMES };
static const char *outcome_names[NOUTCOMES] = {
    "handled", "input", "state", "battery", "phase", "arrival", "leg", "path", "zone", "near", "type"};
static unsigned long long counts[NOUTCOMES];
static unsigned long long edge_clears;     /* segments found clear of a zone by its edges (its box overlapped) */

struct constants {
    const double *c;
    long n_targets, n_zones;
    const double *targets, *zones;
};

/* MissionState's fields (uavsim/strategy.py) */
enum { F_STATE, F_CMD, F_SP, F_CURRENT_TARGET, F_VISITED, F_PHOTO_COUNT, F_LAST_PHOTO_TARGET, F_LAST_PHOTO_TIME,
       F_LAST_PHOTO_X, F_LAST_PHOTO_Y, F_AVOID_COUNT, F_DETOUR, F_PATH, F_PATH_GOAL, F_BRAKING, F_BRAKE_POINT,
       F_COMMAND_TAKEN, NFIELDS };
static const char *field_names[NFIELDS] = {
    "state", "cmd", "sp", "current_target", "visited", "photo_count", "last_photo_target", "last_photo_time",
    "last_photo_x", "last_photo_y", "avoid_count", "detour", "path", "path_goal", "braking", "brake_point",
    "command_taken"};
static PyObject *fields[NFIELDS];

/* the FMU's variables */
enum { V_X, V_Y, V_VX, V_VY, V_PHASE, V_CONSUMED, V_COMMAND, V_CMD, V_SP_X, V_SP_Y, V_SP_Z, V_MISSION_STATE,
       V_TARGETS_ASSIGNED, V_TARGETS_VISITED, V_PHOTO_COUNT, V_LAST_PHOTO_TARGET, V_CURRENT_TARGET, V_AVOIDING,
       V_AVOID_COUNT, V_LAST_PHOTO_TIME, V_LAST_PHOTO_X, V_LAST_PHOTO_Y, NVARIABLES };
static const char *variable_names[NVARIABLES] = {
    "x", "y", "vx", "vy", "phase", "consumed", "command", "cmd", "sp_x", "sp_y", "sp_z", "mission_state",
    "targets_assigned", "targets_visited", "photo_count", "last_photo_target", "current_target", "avoiding",
    "avoid_count", "last_photo_time", "last_photo_x", "last_photo_y"};
static PyObject *variables[NVARIABLES];

/* The mission's fields, each got once (new references, released by release()) */
struct mission {
    PyObject *obj;
    PyObject *v[NFIELDS];
};

/* The fields' descriptors (the slots of MissionState) of the last mission type seen, held: getting a field
 * through its descriptor is what PyObject_GetAttr does for a type with the generic attribute access, without
 * looking the name up along the type's MRO every time (a third of this step's cost).  Any other type, or a
 * Python without PyType_GetSlot for static types (3.9): PyObject_GetAttr and PyObject_SetAttr. */
static PyTypeObject *slots_type, *plain_type;    /* plain_type: the last type seen that has to go by name */
static PyObject *descriptors[NFIELDS];
static descrgetfunc getters[NFIELDS];
static descrsetfunc setters[NFIELDS];

static void forget_slots(void)
{
    for (int f = 0; f < NFIELDS; f++)
        Py_CLEAR(descriptors[f]);
    Py_CLEAR(slots_type);
}

/* 1 when every field of type is a data descriptor whose get and set functions are known, with the generic
 * attribute access (no __getattribute__, __getattr__ or __setattr__ of its own), else 0 */
static int learn_slots(PyTypeObject *type)
{
    forget_slots();
    if (PyType_GetSlot(type, Py_tp_getattro) != (void *)PyObject_GenericGetAttr ||
        PyType_GetSlot(type, Py_tp_setattro) != (void *)PyObject_GenericSetAttr) {
        PyErr_Clear();
        return 0;
    }
    for (int f = 0; f < NFIELDS; f++) {
        PyObject *d = PyObject_GetAttr((PyObject *)type, fields[f]);
        descriptors[f] = d;
        getters[f] = d == NULL ? NULL : (descrgetfunc)PyType_GetSlot(Py_TYPE(d), Py_tp_descr_get);
        setters[f] = d == NULL ? NULL : (descrsetfunc)PyType_GetSlot(Py_TYPE(d), Py_tp_descr_set);
        if (getters[f] == NULL || setters[f] == NULL) {
            PyErr_Clear();
            forget_slots();
            return 0;
        }
    }
    Py_INCREF(type);
    slots_type = type;
    return 1;
}

static int known_slots(PyObject *obj)
{
    if (Py_TYPE(obj) == slots_type)
        return 1;
    if (Py_TYPE(obj) == plain_type)
        return 0;
    if (learn_slots(Py_TYPE(obj)))
        return 1;
    Py_XDECREF(plain_type);
    Py_INCREF(Py_TYPE(obj));
    plain_type = Py_TYPE(obj);
    return 0;
}

/* A field of the mission (borrowed from m), or NULL with the AttributeError set */
static PyObject *field(struct mission *m, int f)
{
    if (m->v[f] == NULL)
        m->v[f] = known_slots(m->obj) ? getters[f](descriptors[f], m->obj, (PyObject *)slots_type)
                                      : PyObject_GetAttr(m->obj, fields[f]);
    return m->v[f];
}

static int set_field(struct mission *m, int f, PyObject *value)
{
    return known_slots(m->obj) ? setters[f](descriptors[f], m->obj, value)
                               : PyObject_SetAttr(m->obj, fields[f], value);
}

static void release(struct mission *m)
{
    for (int f = 0; f < NFIELDS; f++)
        Py_CLEAR(m->v[f]);
}

static int exact_double(PyObject *v, double *out)
{
    if (v == NULL || !PyFloat_CheckExact(v))
        return 0;
    *out = PyFloat_AsDouble(v);
    return 1;
}

static int exact_long(PyObject *v, long *out)
{
    int overflow = 0;
    if (v == NULL || !PyLong_CheckExact(v))
        return 0;
    *out = PyLong_AsLongAndOverflow(v, &overflow);
    return !overflow;
}

/* (x, y) of a tuple or list of two floats (Python unpacks it the same) */
static int point(PyObject *p, double *x, double *y)
{
    PyObject *a, *b;
    if (p == NULL)
        return 0;
    if (PyTuple_Check(p) && PyTuple_Size(p) == 2) {
        a = PyTuple_GetItem(p, 0);
        b = PyTuple_GetItem(p, 1);
    } else if (PyList_Check(p) && PyList_Size(p) == 2) {
        a = PyList_GetItem(p, 0);
        b = PyList_GetItem(p, 1);
    } else {
        return 0;
    }
    return exact_double(a, x) && exact_double(b, y);
}

/* h > r for Python's hypot as surely as for libm's (False when NaN) */
static int clearly_above(double h, double r) { return h > r + SAFE * (fabs(r) + fabs(h)); }
/* h <= r for Python's hypot as surely as for libm's */
static int clearly_below(double h, double r) { return h < r - SAFE * (fabs(r) + fabs(h)); }

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
static int clear_of_zones(const struct constants *k, double ax, double ay, double bx, double by)
{
    const double delta = 1e-9 * (1.0 + fabs(ax) + fabs(ay) + fabs(bx) + fabs(by));
    const double *z = k->zones;
    if (!(delta < INFINITY))
        return 0;
    for (long i = 0; i < k->n_zones; i++, z += 5 + 4 * (z[4] > 0.0 ? (int)z[4] : 0))
        if (!misses_zone(z, ax, ay, bx, by, delta))
            return 0;
    return 1;
}

struct step_in {
    double x, y, vx, vy;
    const struct constants *k;
    struct mission *m;
};

/* Strategy._planned_waypoint without a re-plan, a waypoint reached, a brake or a stop: 1 and the waypoint, or 0
 * with *why set (and an exception when one is set).  (gx, gy): the leg's goal. */
static int planned(const struct step_in *s, double gx, double gy, double *wx, double *wy, int *why)
{
    PyObject *pg, *braking, *path;
    const double x = s->x, y = s->y, vx = s->vx, vy = s->vy, *c = s->k->c;
    double px, py;
    *why = FB_PATH;
    if ((pg = field(s->m, F_PATH_GOAL)) == NULL)
        return 0;
    /* goal != path_goal: a new leg (the goal is a tuple: a path_goal of another type is another leg; a NaN
     * compares unequal here, which only declines) */
    if (!PyTuple_CheckExact(pg) || !point(pg, &px, &py) || !(px == gx && py == gy))
        return 0;
    const double gs = hypot(vx, vy);
    const int moving = clearly_above(gs, 0.5), still = clearly_below(gs, 0.5);
    if (!moving && !still) {
        *why = FB_NEAR;
        return 0;
    }
    if ((braking = field(s->m, F_BRAKING)) == NULL)
        return 0;
    if (braking != Py_False) {
        if (braking == Py_True && moving)     /* braking on: stay at the brake point */
            if (point(field(s->m, F_BRAKE_POINT), wx, wy)) {
                *why = HANDLED;
                return 1;
            }
        return 0;
    }
    if ((path = field(s->m, F_PATH)) == NULL || !PyList_CheckExact(path) || PyList_Size(path) < 1)
        return 0;
    if (!point(PyList_GetItem(path, 0), wx, wy)) {
        *why = FB_TYPE;
        return 0;
    }
    const double dw = hypot(*wx - x, *wy - y);
    if (PyList_Size(path) > 1 && !clearly_above(dw, c[C_RADIUS])) {   /* a waypoint reached (or nearly) */
        *why = FB_ARRIVAL;
        return 0;
    }
    if (moving) {       /* the safety net's look-ahead along the velocity */
        const double stop = c[C_LOOKAHEAD] + gs * gs / (2.0 * c[C_BRAKE]);
        const double la = stop < dw ? stop : dw;
        if (!(la > 2e-9)) {
            *why = FB_NEAR;
            return 0;
        }
        if (!clear_of_zones(s->k, x, y, x + la * vx / gs, y + la * vy / gs)) {
            *why = FB_ZONE;
            return 0;
        }
    }
    if (!clear_of_zones(s->k, x, y, *wx, *wy)) {
        *why = FB_ZONE;
        return 0;
    }
    *why = HANDLED;
    return 1;
}

/* Strategy._reactive_waypoint without a detour vertex reached or a detour planned: 1 and the waypoint, or 0 with
 * *why set (and an exception when one is set). */
static int reactive(const struct step_in *s, double gx, double gy, double *wx, double *wy, int *why)
{
    PyObject *detour = field(s->m, F_DETOUR);
    const double x = s->x, y = s->y, vx = s->vx, vy = s->vy, *c = s->k->c, la = c[C_LOOKAHEAD];
    double ux, uy;
    *why = FB_PATH;
    if (detour == NULL || !PyList_CheckExact(detour))
        return 0;
    if (PyList_Size(detour) == 1)           /* Python drops a lone goal from the detour */
        return 0;
    if (PyList_Size(detour) > 1) {           /* flying a detour: to its next vertex unless reached or blocked */
        if (!point(PyList_GetItem(detour, 0), wx, wy)) {
            *why = FB_TYPE;
            return 0;
        }
        if (!clearly_above(hypot(*wx - x, *wy - y), c[C_RADIUS])) {
            *why = FB_ARRIVAL;
            return 0;
        }
        if (!clear_of_zones(s->k, x, y, *wx, *wy)) {
            *why = FB_ZONE;
            return 0;
        }
        *why = HANDLED;
        return 1;
    }
    const double gs = hypot(vx, vy), dx = gx - x, dy = gy - y, dd = hypot(dx, dy);
    *wx = gx;
    *wy = gy;
    *why = FB_NEAR;
    if (clearly_above(gs, 0.5)) {
        ux = vx / gs;
        uy = vy / gs;
    } else if (clearly_below(gs, 0.5)) {
        if (clearly_below(dd, 1e-9)) {       /* on the goal: Python returns it without a test */
            *why = HANDLED;
            return 1;
        }
        if (!clearly_above(dd, 1e-9))
            return 0;
        ux = dx / dd;
        uy = dy / dd;
    } else {
        return 0;
    }
    if (!clear_of_zones(s->k, x, y, x + la * ux, y + la * uy)) {
        *why = FB_ZONE;
        return 0;
    }
    /* the segment toward the goal (Strategy._towards): the goal itself within la, else la along the way */
    if (clearly_below(dd, la) || clearly_below(dd, 1e-9)) {
        if (!clear_of_zones(s->k, x, y, gx, gy)) {
            *why = FB_ZONE;
            return 0;
        }
    } else if (clearly_above(dd, la) && clearly_above(dd, 1e-9)) {
        if (!clear_of_zones(s->k, x, y, x + la * dx / dd, y + la * dy / dd)) {
            *why = FB_ZONE;
            return 0;
        }
    } else {
        return 0;
    }
    *why = HANDLED;
    return 1;
}

/* The new mission.sp, (float(wx), float(wy), cruise_altitude): the current tuple when it holds those values
 * already (the common case: the same waypoint as last step); a new reference, or NULL on an error. */
static PyObject *setpoint(PyObject *sp, double wx, double wy, double cruise)
{
    PyObject *a, *b, *z, *out;
    if (PyTuple_CheckExact(sp) && PyTuple_Size(sp) == 3) {
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

/* Strategy.outputs() but cmd and the setpoint, gathered before anything is written: 1, or 0 (declined; an
 * exception when one is set) */
struct published {
    PyObject *src[8];                   /* published as they are (keys: out_vars) */
    Py_ssize_t visited;
    int avoiding;
};

static const int src_fields[8] = {F_STATE, F_PHOTO_COUNT, F_LAST_PHOTO_TARGET, F_CURRENT_TARGET, F_AVOID_COUNT,
                                  F_LAST_PHOTO_TIME, F_LAST_PHOTO_X, F_LAST_PHOTO_Y};
static const int out_vars[8] = {V_MISSION_STATE, V_PHOTO_COUNT, V_LAST_PHOTO_TARGET, V_CURRENT_TARGET,
                                V_AVOID_COUNT, V_LAST_PHOTO_TIME, V_LAST_PHOTO_X, V_LAST_PHOTO_Y};

static int gather(struct mission *m, int planning, struct published *p)
{
    PyObject *visited;
    for (int i = 0; i < 8; i++)
        if ((p->src[i] = field(m, src_fields[i])) == NULL)
            return 0;
    if ((visited = field(m, F_VISITED)) == NULL || !PyList_CheckExact(visited))
        return 0;
    p->visited = PyList_Size(visited);
    if (planning) {       /* Strategy.outputs(): braking or a path with detour vertices */
        PyObject *braking = field(m, F_BRAKING), *path;
        if (braking == NULL || (path = field(m, F_PATH)) == NULL)
            return 0;
        if ((braking != Py_True && braking != Py_False) || !PyList_CheckExact(path))
            return 0;
        p->avoiding = braking == Py_True || PyList_Size(path) > 1;
    } else {
        PyObject *detour = field(m, F_DETOUR);
        if (detour == NULL || !PyList_CheckExact(detour))
            return 0;
        p->avoiding = PyList_Size(detour) > 0;
    }
    return 1;
}

/* variables[var] = value, unless it holds that object already (the common step leaves most outputs as they are:
 * a lookup costs a third of a store) */
static int publish(PyObject *d, int var, PyObject *value)
{
    PyObject *now = PyDict_GetItemWithError(d, variables[var]);
    if (now == value)
        return 0;
    return now == NULL && PyErr_Occurred() ? -1 : PyDict_SetItem(d, variables[var], value);
}

static int publish_size(PyObject *d, int var, Py_ssize_t n)
{
    PyObject *now = PyDict_GetItemWithError(d, variables[var]), *v;
    int rc;
    if (now != NULL && PyLong_CheckExact(now) && PyLong_AsSsize_t(now) == n)
        return 0;
    if (PyErr_Occurred())
        return -1;
    v = PyLong_FromSsize_t(n);
    rc = v == NULL ? -1 : PyDict_SetItem(d, variables[var], v);
    Py_XDECREF(v);
    return rc;
}

/* Strategy.step's effects (mission.cmd, mission.sp) and the shell's _publish */
static int commit(PyObject *d, struct mission *m, PyObject *cmd, PyObject *sp, double assigned,
                  const struct published *p)
{
    /* (the common step keeps the setpoint the mission holds: nothing to set) */
    if (set_field(m, F_CMD, cmd) < 0 || (m->v[F_SP] != sp && set_field(m, F_SP, sp) < 0))
        return -1;
    if (publish(d, V_CMD, cmd) < 0 || publish(d, V_SP_X, PyTuple_GetItem(sp, 0)) < 0 ||
        publish(d, V_SP_Y, PyTuple_GetItem(sp, 1)) < 0 || publish(d, V_SP_Z, PyTuple_GetItem(sp, 2)) < 0 ||
        publish_size(d, V_TARGETS_ASSIGNED, (Py_ssize_t)assigned) < 0 ||
        publish_size(d, V_TARGETS_VISITED, p->visited) < 0 || publish(d, V_AVOIDING, small_int[p->avoiding]) < 0)
        return -1;
    for (int i = 0; i < 8; i++)
        if (publish(d, out_vars[i], p->src[i]) < 0)
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

/* The waypoint of an airborne step without any event: 1 and the waypoint, or 0 with *why set (and an exception
 * when one is set) */
static int en_route(const struct step_in *s, long state, double *wx, double *wy, int *why)
{
    const double *c = s->k->c;
    double gx, gy;
    if (state == TRANSIT) {
        long target;
        *why = FB_LEG;
        if (!exact_long(field(s->m, F_CURRENT_TARGET), &target) || target < 0 || target >= s->k->n_targets)
            return 0;
        gx = s->k->targets[2 * target];
        gy = s->k->targets[2 * target + 1];
        if (!clearly_above(hypot(gx - s->x, gy - s->y), c[C_RADIUS])) {     /* a photo (or nearly) */
            *why = FB_ARRIVAL;
            return 0;
        }
    } else {
        gx = c[C_HOME_X];
        gy = c[C_HOME_Y];
        if (!clearly_above(hypot(s->x - gx, s->y - gy), c[C_RADIUS])) {     /* at the base (or nearly) */
            *why = FB_ARRIVAL;
            return 0;
        }
    }
    if (s->k->n_zones == 0) {
        *wx = gx;
        *wy = gy;
        *why = HANDLED;
        return 1;
    }
    return c[C_PLANNING] != 0.0 ? planned(s, gx, gy, wx, wy, why) : reactive(s, gx, gy, wx, wy, why);
}

/* The constants' layout checked against their length: 1, or 0 (declined) */
static int unpack_constants(PyObject *constants, struct constants *k)
{
    const Py_ssize_t n = PyBytes_Check(constants) ? PyBytes_Size(constants) / (Py_ssize_t)sizeof(double) : 0;
    if (n < C_TARGETS)
        return 0;
    k->c = (const double *)PyBytes_AsString(constants);
    k->n_targets = (long)k->c[C_NTARGETS];
    k->n_zones = (long)k->c[C_NZONES];
    if (k->n_targets < 0 || k->n_zones < 0 || n < C_TARGETS + 2 * k->n_targets + 5 * k->n_zones)
        return 0;
    k->targets = k->c + C_TARGETS;
    k->zones = k->targets + 2 * k->n_targets;
    return 1;
}

static PyObject *step(PyObject *module, PyObject *args)
{
    PyObject *constants, *d, *cmd, *sp = NULL, *result = Py_False;
    struct constants k;
    struct mission m = {NULL, {NULL}};
    struct step_in s;
    struct published pub;
    double consumed, wx = 0.0, wy = 0.0;
    long phase, state;
    int why = FB_INPUT, en_route_step = 0;
    (void)module;
    if (!PyArg_UnpackTuple(args, "step", 3, 3, &constants, &m.obj, &d))
        return NULL;
    if (!PyDict_Check(d)) {
        PyErr_SetString(PyExc_TypeError, "step(constants, mission, variables: dict)");
        return NULL;
    }
    s.k = &k;
    s.m = &m;
    /* a command to take: Python's (ints compare by identity only when small: a new one then) */
    if (!exact_double(PyDict_GetItemWithError(d, variables[V_X]), &s.x) ||
        !exact_double(PyDict_GetItemWithError(d, variables[V_Y]), &s.y) ||
        !exact_double(PyDict_GetItemWithError(d, variables[V_VX]), &s.vx) ||
        !exact_double(PyDict_GetItemWithError(d, variables[V_VY]), &s.vy) ||
        !exact_double(PyDict_GetItemWithError(d, variables[V_CONSUMED]), &consumed) ||
        !exact_long(PyDict_GetItemWithError(d, variables[V_PHASE]), &phase))
        goto done;
    {
        PyObject *command = PyDict_GetItemWithError(d, variables[V_COMMAND]), *taken;
        if (command == NULL || (taken = field(&m, F_COMMAND_TAKEN)) == NULL || command != taken)
            goto done;
    }
    why = FB_STATE;
    if (!unpack_constants(constants, &k) || !exact_long(field(&m, F_STATE), &state))
        goto done;
    const double *c = k.c;
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
        if (phase == 1 || phase == 2 || (phase == 3 && consumed >= c[C_LAND]))
            goto done;
        cmd = small_int[1];
        break;
    case TAKEOFF:
        why = FB_PHASE;
        if (phase == 2)
            goto done;          /* climb done: the first leg starts */
        why = FB_BATTERY;
        if (!battery_quiet(c, phase, consumed, state))
            goto done;
        cmd = small_int[1];
        break;
    case TRANSIT:
    case RETURN_DONE:
    case RETURN_LOW:
    case RETURN_CMD:
        why = FB_BATTERY;
        if (!battery_quiet(c, phase, consumed, state))
            goto done;
        why = FB_PHASE;
        if (phase == 4)
            goto done;
        if (!en_route(&s, state, &wx, &wy, &why))
            goto done;
        en_route_step = 1;
        cmd = small_int[2];
        break;
    default:
        goto done;
    }
    why = FB_TYPE;
    if ((sp = field(&m, F_SP)) == NULL)
        goto done;
    if (en_route_step)
        sp = setpoint(sp, wx, wy, c[C_CRUISE]);
    else
        Py_INCREF(sp);
    if (sp == NULL)
        goto error;
    if (!PyTuple_CheckExact(sp) || PyTuple_Size(sp) != 3 || !gather(&m, c[C_PLANNING] != 0.0, &pub))
        goto done;
    if (commit(d, &m, cmd, sp, c[C_ASSIGNED], &pub) < 0)
        goto error;
    why = HANDLED;
    result = Py_True;
done:
    if (PyErr_Occurred())
        goto error;
    counts[why]++;
    Py_XDECREF(sp);
    release(&m);
    Py_INCREF(result);
    return result;
error:
    Py_XDECREF(sp);
    release(&m);
    return NULL;
}

static PyObject *stats(PyObject *module, PyObject *unused)
{
    PyObject *out = PyDict_New();
    (void)module;
    (void)unused;
    for (int i = 0; out != NULL && i <= NOUTCOMES; i++) {
        PyObject *v = PyLong_FromUnsignedLongLong(i < NOUTCOMES ? counts[i] : edge_clears);
        if (v == NULL || PyDict_SetItemString(out, i < NOUTCOMES ? outcome_names[i] : "edge_clears", v) < 0) {
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
    {"step", step, METH_VARARGS,
     "step(constants, mission, variables) -> True when the step was done here (mission and output variables "
     "updated), False when nothing was changed and Python must run it"},
    {"stats", stats, METH_NOARGS,
     "counts of the steps done here ('handled'), of each reason to decline, and of the segments found clear of "
     "a zone by its edges ('edge_clears')"},
    {"reset_stats", reset_stats, METH_NOARGS, "zero the counts"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module_def = {PyModuleDef_HEAD_INIT, "_strategy_ext",
                                        "The UavStrategy FMU's step in C (see _strategy_ext.c)", -1, methods,
                                        NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__strategy_ext(void)
{
    for (int i = 0; i < NFIELDS; i++)
        if ((fields[i] = PyUnicode_InternFromString(field_names[i])) == NULL)
            return NULL;
    for (int i = 0; i < NVARIABLES; i++)
        if ((variables[i] = PyUnicode_InternFromString(variable_names[i])) == NULL)
            return NULL;
    for (int i = 0; i < 4; i++)
        if ((small_int[i] = PyLong_FromLong(i)) == NULL)
            return NULL;
    return PyModule_Create(&module_def);
}

/* The UavDynamics FMU's step in C: the accelerator of the shell's Python step (fmu_sources/UavDynamics.py do_step
 * -> uavsim.dynamics.Dynamics.step + Dynamics.outputs) and of its lat/lon/alt properties (UavDynamics.geodetic),
 * declared in uavsim/accelerators.py and checked against them by the accelerator harness (tests/accelerators/).
 *
 * step(model, variables, step_size) advances the Dynamics ``model`` (its state stays in the model's fields, as
 * Dynamics.run_substeps leaves them, so FMU get/set state, the properties and the Python step see the same object)
 * and publishes the outputs.  What it reads and writes, all public:
 * - model: the Dynamics' fields, got and set by their names: step_constants (kernels.c's parameter slots, then
 *   preflight_time and g, as native doubles), substep_table (step size -> (sub-steps, sub-step)), pos, vel, vt,
 *   vtz, integ, hold, hold_z, mode, a_cmd, phase, ready, preflight_elapsed, time, wind; and its methods
 *   run_substeps (lift-off, the sub-steps after a touch-down: the Python code) and touch_down;
 * - variables: the FMU's variables by their modelDescription names (the shell's variable values): the inputs
 *   cmd, sp_x, sp_y, sp_z, wind_x, wind_y, wind_z and the outputs x, y, z, vx, vy, vz, airspeed, groundspeed,
 *   tilt, phase, ready.
 * The flying sub-steps are uav_fly of kernels.c, the loop Dynamics.run_substeps calls through ctypes.  It returns
 * False without changing anything when the Python code must do the whole step (no model yet, a step size not
 * seen before, a value it cannot convert: the Python code then raises the error it always raised).
 *
 * lat(shell), lon(shell), alt(shell) are the shell's properties: the conversion of its (x, y, z) by its
 * enu_frame (EnuFrame.constants), cached in its geodetic_key and geodetic_value as UavDynamics.geodetic caches it.
 *
 * Bit-identity: the arithmetic is kernels.c's; the published speeds use Python's own math.hypot (not libm's
 * hypot: CPython rounds differently), called through the function object.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <string.h>

#include "kernels.c"

enum { PREFLIGHT = 0, ON_GROUND = 4 };   /* phases (LANDED is a state slot) */
enum { CMD_TAKEOFF = 1 };
/* Dynamics.step_constants: kernels.c's parameter slots, then these two */
enum { K_PREFLIGHT_TIME = NPARAM, K_G, NKBUF };

static PyObject *hypot_fn;
static PyObject *str_goto, *str_hold, *str_run, *str_touch_down;
/* variables */
static PyObject *k_cmd, *k_sp[3], *k_wind[3], *k_x, *k_y, *k_z, *k_vx, *k_vy, *k_vz, *k_airspeed,
    *k_groundspeed, *k_tilt, *k_phase, *k_ready;
/* model fields (k_phase and k_ready too) */
static PyObject *k_sub, *k_kbuf, *k_pos, *k_vel, *k_vt, *k_vtz, *k_integ, *k_hold, *k_hold_z, *k_mode, *k_a_cmd,
    *k_wind_m, *k_preflight_elapsed, *k_time;
/* geodetic outputs: the shell's fields and EnuFrame.constants */
static PyObject *str_geodetic, *k_frame, *k_geo, *k_geo_key, *k_constants;

/* ------------------------------------------------------------------ small helpers (0 / NULL: a Python error) */

/* d[key] borrowed, NULL when missing (PyDict_GetItem would also save and restore the error state: slower) */
static PyObject *lookup(PyObject *d, PyObject *key) { return PyDict_GetItemWithError(d, key); }

/* obj.name as a double */
static int field_double(PyObject *obj, PyObject *name, double *out)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    if (v == NULL) return 0;
    *out = PyFloat_AsDouble(v);
    Py_DECREF(v);
    return !(*out == -1.0 && PyErr_Occurred());
}

/* obj.name, an int, as a long */
static int field_long(PyObject *obj, PyObject *name, long *out)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    int ok = v != NULL && PyLong_Check(v);
    if (ok) *out = PyLong_AsLong(v);
    Py_XDECREF(v);
    return ok && !(*out == -1 && PyErr_Occurred());
}

/* the list obj.name (a new reference) of n numbers, read into out[0..n-1]; NULL: not such a list */
static PyObject *field_list(PyObject *obj, PyObject *name, double *out, Py_ssize_t n)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    if (v == NULL) return NULL;
    if (!PyList_CheckExact(v) || PyList_Size(v) != n) { Py_DECREF(v); return NULL; }
    for (Py_ssize_t i = 0; i < n; i++) {
        out[i] = PyFloat_AsDouble(PyList_GetItem(v, i));
        if (out[i] == -1.0 && PyErr_Occurred()) { Py_DECREF(v); return NULL; }
    }
    return v;
}

/* d[key] = value, stealing the reference to value */
static int put(PyObject *d, PyObject *key, PyObject *value)
{
    int rc;
    if (value == NULL) return 0;
    rc = PyDict_SetItem(d, key, value);
    Py_DECREF(value);
    return rc == 0;
}

static int put_double(PyObject *d, PyObject *key, double x) { return put(d, key, PyFloat_FromDouble(x)); }

/* obj.name = value, stealing the reference to value */
static int set_field(PyObject *obj, PyObject *name, PyObject *value)
{
    int rc;
    if (value == NULL) return 0;
    rc = PyObject_SetAttr(obj, name, value);
    Py_DECREF(value);
    return rc == 0;
}

static int set_field_double(PyObject *obj, PyObject *name, double x)
{
    return set_field(obj, name, PyFloat_FromDouble(x));
}

/* the same IEEE double, bit for bit (0.0 and -0.0 differ) */
static int same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* list[0..n-1] = x, in place, as Dynamics._substep updates its lists (a new list would cost an allocation and the
 * garbage collector's tracking); an item that keeps its value keeps its float object */
static int set_list(PyObject *list, const double *x, Py_ssize_t n)
{
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *old = PyList_GetItem(list, i), *f;
        if (PyFloat_CheckExact(old) && same_bits(PyFloat_AsDouble(old), x[i])) continue;
        if ((f = PyFloat_FromDouble(x[i])) == NULL) return 0;
        PyList_SetItem(list, i, f);
    }
    return 1;
}

/* the list obj.name (a new reference), known to be a list of n items, or a new list set as obj.name (NULL: error) */
static PyObject *list_field(PyObject *obj, PyObject *name, Py_ssize_t n)
{
    PyObject *list = PyObject_GetAttr(obj, name);
    if (list != NULL && PyList_CheckExact(list) && PyList_Size(list) == n) return list;
    Py_XDECREF(list);
    PyErr_Clear();
    if ((list = PyList_New(n)) == NULL) return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        Py_INCREF(Py_None);
        PyList_SetItem(list, i, Py_None);
    }
    if (PyObject_SetAttr(obj, name, list) < 0) { Py_DECREF(list); return NULL; }
    return list;
}

/* obj.name = x unless old, the float object obj.name holds, holds x already */
static int update_double(PyObject *obj, PyObject *name, PyObject *old, double x)
{
    if (PyFloat_CheckExact(old) && same_bits(PyFloat_AsDouble(old), x)) return 1;
    return set_field_double(obj, name, x);
}

/* float(d[key]), as a new reference */
static PyObject *as_float(PyObject *d, PyObject *key)
{
    PyObject *v = lookup(d, key);
    return v == NULL ? NULL : PyNumber_Float(v);
}

/* float(d[key]) into *out (0: error) */
static int get_float(PyObject *d, PyObject *key, double *out)
{
    PyObject *f = as_float(d, key);
    if (f == NULL) return 0;
    *out = PyFloat_AsDouble(f);
    Py_DECREF(f);
    return 1;
}

/* (sp_x, sp_y, sp_z) of the variables, as the shell's do_step passes them to Dynamics.step */
static PyObject *sp_tuple(PyObject *sd)
{
    PyObject *x = lookup(sd, k_sp[0]), *y = lookup(sd, k_sp[1]), *z = lookup(sd, k_sp[2]);
    if (x == NULL || y == NULL || z == NULL) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_AttributeError, "sp_x, sp_y or sp_z");
        return NULL;
    }
    return PyTuple_Pack(3, x, y, z);
}

/* Python's math.hypot(a, b) */
static int py_hypot(PyObject *a, PyObject *b, double *out)
{
    PyObject *r = PyObject_CallFunctionObjArgs(hypot_fn, a, b, NULL);
    if (r == NULL) return 0;
    *out = PyFloat_AsDouble(r);
    Py_DECREF(r);
    return 1;
}

/* ------------------------------------------------------------------ the step */

/* what the shell publishes is read from (references owned by the view: release_view) */
typedef struct {
    PyObject *pos, *vel, *a_cmd, *ready;
    double w0, w1;
    long phase;
} View;

static void release_view(View *v)
{
    Py_CLEAR(v->pos); Py_CLEAR(v->vel); Py_CLEAR(v->a_cmd); Py_CLEAR(v->ready);
}

/* the view of a model's state in its fields, its wind and phase known (0: error) */
static int read_view_known(PyObject *model, View *v, double w0, double w1, long phase)
{
    v->pos = PyObject_GetAttr(model, k_pos);
    v->vel = PyObject_GetAttr(model, k_vel);
    v->a_cmd = PyObject_GetAttr(model, k_a_cmd);
    v->ready = PyObject_GetAttr(model, k_ready);
    v->w0 = w0; v->w1 = w1; v->phase = phase;
    return !(v->pos == NULL || v->vel == NULL || v->a_cmd == NULL || v->ready == NULL
             || !PyList_Check(v->pos) || PyList_Size(v->pos) != 3 || !PyList_Check(v->vel) || PyList_Size(v->vel) != 3
             || !PyList_Check(v->a_cmd) || PyList_Size(v->a_cmd) != 2);
}

/* the view of a model's state in its fields (0: error) */
static int read_view(PyObject *model, View *v)
{
    PyObject *w = PyObject_GetAttr(model, k_wind_m), *phase = PyObject_GetAttr(model, k_phase);
    int ok;
    v->pos = PyObject_GetAttr(model, k_pos);
    v->vel = PyObject_GetAttr(model, k_vel);
    v->a_cmd = PyObject_GetAttr(model, k_a_cmd);
    v->ready = PyObject_GetAttr(model, k_ready);
    ok = !(v->pos == NULL || v->vel == NULL || v->a_cmd == NULL || v->ready == NULL || w == NULL || phase == NULL
           || !PyList_Check(v->pos) || PyList_Size(v->pos) != 3 || !PyList_Check(v->vel) || PyList_Size(v->vel) != 3
           || !PyList_Check(v->a_cmd) || PyList_Size(v->a_cmd) != 2 || !PyTuple_Check(w) || PyTuple_Size(w) != 3
           || !PyLong_Check(phase));
    if (ok) {
        v->w0 = PyFloat_AsDouble(PyTuple_GetItem(w, 0));
        v->w1 = PyFloat_AsDouble(PyTuple_GetItem(w, 1));
        v->phase = PyLong_AsLong(phase);
        ok = !PyErr_Occurred();
    }
    Py_XDECREF(w);
    Py_XDECREF(phase);
    return ok;
}

/* One pass of Dynamics.run_substeps' loop body through uav_fly from sub-step i: the state in and out of the model's
 * fields, and *v the view of it.  Returns the sub-step reached (-1: error) and sets *landed. */
static long fly(PyObject *model, const double *p, long phase, long i, long n, double h, long cmd, const double *sp,
                double wx, double wy, View *v, int *landed)
{
    double s[NSTATE], pos[3], vel[3], vt[2], integ[2], hold[2];
    PyObject *mode = PyObject_GetAttr(model, k_mode), *vtz = PyObject_GetAttr(model, k_vtz),
             *hold_z = PyObject_GetAttr(model, k_hold_z);
    PyObject *pos_l = NULL, *vel_l = NULL, *vt_l = NULL, *integ_l = NULL, *hold_l = NULL, *a_l = NULL;
    long result = -1;
    int goto_;
    if (mode == NULL || vtz == NULL || hold_z == NULL || (pos_l = field_list(model, k_pos, pos, 3)) == NULL
        || (vel_l = field_list(model, k_vel, vel, 3)) == NULL || (vt_l = field_list(model, k_vt, vt, 2)) == NULL
        || (integ_l = field_list(model, k_integ, integ, 2)) == NULL
        || (hold_l = field_list(model, k_hold, hold, 2)) == NULL || (a_l = list_field(model, k_a_cmd, 2)) == NULL)
        goto done;
    s[VTZ] = PyFloat_AsDouble(vtz);
    s[HOLDZ] = PyFloat_AsDouble(hold_z);
    if (PyErr_Occurred()) goto done;
    goto_ = PyObject_RichCompareBool(mode, str_goto, Py_EQ);
    if (goto_ < 0) goto done;
    s[PX] = pos[0]; s[PY] = pos[1]; s[PZ] = pos[2]; s[VX] = vel[0]; s[VY] = vel[1];
    s[VTX] = vt[0]; s[VTY] = vt[1]; s[IX] = integ[0]; s[IY] = integ[1]; s[AX] = 0.0; s[AY] = 0.0;
    s[HX] = hold[0]; s[HY] = hold[1]; s[PHASE] = (double)phase; s[MODE] = goto_ ? 1.0 : 0.0; s[LANDED] = 0.0;
    s[I] = (double)i; s[N] = (double)n; s[H] = h; s[CMD] = (double)cmd;
    s[SPX] = sp[0]; s[SPY] = sp[1]; s[SPZ] = sp[2]; s[WX] = wx; s[WY] = wy;
    i = uav_fly(s, p);
    {   /* Dynamics.run_substeps' assignments */
        const double newpos[3] = {s[PX], s[PY], s[PZ]}, newvel[3] = {s[VX], s[VY], s[VTZ]};
        const double newvt[2] = {s[VTX], s[VTY]}, newinteg[2] = {s[IX], s[IY]}, acmd[2] = {s[AX], s[AY]};
        const double newhold[2] = {s[HX], s[HY]};
        PyObject *m = s[MODE] != 0.0 ? str_goto : str_hold;
        if (!set_list(pos_l, newpos, 3) || !set_list(vel_l, newvel, 3) || !set_list(vt_l, newvt, 2)
            || !update_double(model, k_vtz, vtz, s[VTZ]) || !set_list(integ_l, newinteg, 2) || !set_list(a_l, acmd, 2)
            || ((long)s[PHASE] != phase && !set_field(model, k_phase, PyLong_FromLong((long)s[PHASE])))
            || (m != mode && PyObject_SetAttr(model, k_mode, m) < 0)
            || !set_list(hold_l, newhold, 2) || !update_double(model, k_hold_z, hold_z, s[HOLDZ]))
            goto done;
    }
    if ((v->ready = PyObject_GetAttr(model, k_ready)) == NULL) goto done;
    v->pos = pos_l; v->vel = vel_l; v->a_cmd = a_l;     /* the view takes these references over */
    pos_l = vel_l = a_l = NULL;
    v->w0 = wx; v->w1 = wy;
    v->phase = (long)s[PHASE];
    *landed = s[LANDED] != 0.0;
    result = i;
done:
    Py_XDECREF(mode); Py_XDECREF(vtz); Py_XDECREF(hold_z);
    Py_XDECREF(pos_l); Py_XDECREF(vel_l); Py_XDECREF(vt_l); Py_XDECREF(integ_l); Py_XDECREF(hold_l); Py_XDECREF(a_l);
    return result;
}

/* model.run_substeps(n, h, cmd, sp[, i]): the reference code, for the rare sub-steps (0: error) */
static int run_python(PyObject *model, long n, double h, long cmd, PyObject *sp, long i)
{
    PyObject *r = NULL, *ni = PyLong_FromLong(n), *hi = PyFloat_FromDouble(h), *ci = PyLong_FromLong(cmd),
             *ii = PyLong_FromLong(i);
    if (ni && hi && ci && ii) r = PyObject_CallMethodObjArgs(model, str_run, ni, hi, ci, sp, ii, NULL);
    Py_XDECREF(ni); Py_XDECREF(hi); Py_XDECREF(ci); Py_XDECREF(ii);
    Py_XDECREF(r);
    return r != NULL;
}

/* Dynamics.step's phase dispatch, once the inputs are read; fills *v with the view to publish (0: error) */
static int advance(PyObject *model, const double *p, long n, double h, long cmd, PyObject *sd, double wx, double wy,
                   View *v)
{
    long phase;
    if (!field_long(model, k_phase, &phase)) return 0;
    if (phase == PREFLIGHT && cmd != CMD_TAKEOFF && cmd != CMD_GOTO) {  /* only the preflight clock runs */
        const double pt = p[K_PREFLIGHT_TIME] - 1e-9;
        double elapsed;
        int ready = 0;
        if (!field_double(model, k_preflight_elapsed, &elapsed)) return 0;
        for (long j = 0; j < n; j++) {
            elapsed += h;
            if (elapsed >= pt) ready = 1;
        }
        if (!set_field_double(model, k_preflight_elapsed, elapsed)) return 0;
        if (ready && PyObject_SetAttr(model, k_ready, Py_True) < 0) return 0;
        return read_view_known(model, v, wx, wy, phase);      /* the phase and the wind as they were */
    } else if (phase == PREFLIGHT || (phase == ON_GROUND && cmd == CMD_TAKEOFF)) {
        /* lift-off: the reference code */
        PyObject *sp = sp_tuple(sd);
        int ok = sp != NULL && run_python(model, n, h, cmd, sp, 0);
        Py_XDECREF(sp);
        if (!ok) return 0;
    } else if (phase != ON_GROUND) {     /* flying (on the ground without a takeoff command nothing changes) */
        double spd[3];
        int landed = 0;
        long i;
        for (int j = 0; j < 3; j++)
            if (!get_float(sd, k_sp[j], &spd[j])) return 0;
        i = fly(model, p, phase, 0, n, h, cmd, spd, wx, wy, v, &landed);
        if (i < 0) return 0;
        if (!landed) return 1;
        release_view(v);
        {
            PyObject *r = PyObject_CallMethodObjArgs(model, str_touch_down, NULL), *sp;
            int ok;
            if (r == NULL) return 0;
            Py_DECREF(r);
            /* touched down before the end of the step: the rest (on the ground) in Python, from sub-step i */
            if (i < n) {
                sp = sp_tuple(sd);
                ok = sp != NULL && run_python(model, n, h, cmd, sp, i);
                Py_XDECREF(sp);
                if (!ok) return 0;
            }
        }
    } else {
        return read_view_known(model, v, wx, wy, phase);      /* on the ground: nothing changed */
    }
    return read_view(model, v);
}

/* Dynamics.outputs() of the view into the variables, as UavDynamics._publish assigns them (0: error) */
static int publish(PyObject *sd, const double *p, const View *v)
{
    PyObject *vx = PyList_GetItem(v->vel, 0), *vy = PyList_GetItem(v->vel, 1), *gx, *gy, *phase, *ready;
    double v0 = PyFloat_AsDouble(vx), v1 = PyFloat_AsDouble(vy), air, ground, amag;
    int ok, push = p[PUSH] != 0.0;
    if (PyErr_Occurred()) return 0;
    if (push && (v->phase == TAKEOFF || v->phase == FLY || v->phase == LAND)) {
        gx = PyFloat_FromDouble(v0 + v->w0);
        gy = PyFloat_FromDouble(v1 + v->w1);
    } else {
        gx = vx; Py_INCREF(gx);
        gy = vy; Py_INCREF(gy);
    }
    if (gx == NULL || gy == NULL) { Py_XDECREF(gx); Py_XDECREF(gy); return 0; }
    ok = py_hypot(gx, gy, &ground);
    /* in still air the air-relative and ground velocities differ at most in the sign of a zero, which hypot
     * ignores: one call serves both */
    if (ok && v->w0 == 0.0 && v->w1 == 0.0) {
        air = ground;
    } else if (ok && push) {
        ok = py_hypot(vx, vy, &air);
    } else if (ok) {
        PyObject *dx = PyFloat_FromDouble(v0 - v->w0), *dy = PyFloat_FromDouble(v1 - v->w1);
        ok = dx != NULL && dy != NULL && py_hypot(dx, dy, &air);
        Py_XDECREF(dx); Py_XDECREF(dy);
    }
    if (ok) {
        PyObject *ax = PyList_GetItem(v->a_cmd, 0), *ay = PyList_GetItem(v->a_cmd, 1);
        double a0 = PyFloat_AsDouble(ax), a1 = PyFloat_AsDouble(ay);
        if (a0 == 0.0 && a1 == 0.0)      /* no thrust demand (on the ground): hypot is +0.0 */
            amag = 0.0;
        else
            ok = !PyErr_Occurred() && py_hypot(ax, ay, &amag);
    }
    if (!ok) { Py_DECREF(gx); Py_DECREF(gy); return 0; }
    phase = PyLong_FromLong(v->phase);
    ready = PyNumber_Long(v->ready);
    if (phase == NULL || ready == NULL) { Py_DECREF(gx); Py_DECREF(gy); Py_XDECREF(phase); Py_XDECREF(ready); return 0; }
    for (int j = 0; j < 3; j++) Py_INCREF(PyList_GetItem(v->pos, j));
    Py_INCREF(PyList_GetItem(v->vel, 2));
    /* math.degrees(x) is x * (180 / pi); each put takes over its reference, whatever happens */
    ok = put(sd, k_x, PyList_GetItem(v->pos, 0));
    ok &= put(sd, k_y, PyList_GetItem(v->pos, 1));
    ok &= put(sd, k_z, PyList_GetItem(v->pos, 2));
    ok &= put(sd, k_vx, gx);
    ok &= put(sd, k_vy, gy);
    ok &= put(sd, k_vz, PyList_GetItem(v->vel, 2));
    ok &= put_double(sd, k_airspeed, air);
    ok &= put_double(sd, k_groundspeed, ground);
    ok &= put_double(sd, k_tilt, (180.0 / Py_MATH_PI) * atan2(amag, p[K_G]));
    ok &= put(sd, k_phase, phase);
    ok &= put(sd, k_ready, ready);
    return ok;
}

/* int(cmd) and the wind tuple of Dynamics.step, as UavDynamics.do_step passes them (0: the Python code must do
 * the step) */
static int read_inputs(PyObject *sd, long *cmd, PyObject **wind)
{
    PyObject *c = lookup(sd, k_cmd), *ci;
    *wind = NULL;
    if (c == NULL || (ci = PyNumber_Long(c)) == NULL) return 0;
    *cmd = PyLong_AsLong(ci);
    Py_DECREF(ci);
    if ((*cmd == -1 && PyErr_Occurred()) || (*wind = PyTuple_New(3)) == NULL) return 0;
    for (int j = 0; j < 3; j++) {
        PyObject *w = as_float(sd, k_wind[j]);
        if (w == NULL) return 0;
        PyTuple_SetItem(*wind, j, w);
    }
    return 1;
}

static PyObject *step(PyObject *module, PyObject *args)
{
    PyObject *model, *sd, *dt_o, *sub = NULL, *nh, *kbuf = NULL, *wind = NULL;
    const double *p;
    double dt, h, time;
    long n, cmd;
    View v = {NULL, NULL, NULL, NULL, 0.0, 0.0, 0};
    int ok = 0;
    (void)module;
    if (PyTuple_Size(args) != 3 || !PyDict_Check(sd = PyTuple_GetItem(args, 1))) {
        PyErr_SetString(PyExc_TypeError, "step(model, variables, step_size)");
        return NULL;
    }
    model = PyTuple_GetItem(args, 0);
    dt_o = PyTuple_GetItem(args, 2);
    dt = PyFloat_AsDouble(dt_o);
    if (model == Py_None || (dt == -1.0 && PyErr_Occurred()) || !(dt > 0.0))
        goto python;
    /* the model's sub-division of this step size (a new one: the Python code computes it) */
    if ((sub = PyObject_GetAttr(model, k_sub)) == NULL || (kbuf = PyObject_GetAttr(model, k_kbuf)) == NULL)
        goto python;
    nh = PyDict_Check(sub) ? lookup(sub, dt_o) : NULL;
    if (nh == NULL || !PyTuple_Check(nh) || PyTuple_Size(nh) != 2 || !PyBytes_Check(kbuf)
        || PyBytes_Size(kbuf) != NKBUF * (Py_ssize_t)sizeof(double))
        goto python;
    n = PyLong_AsLong(PyTuple_GetItem(nh, 0));
    h = PyFloat_AsDouble(PyTuple_GetItem(nh, 1));
    if (PyErr_Occurred() || !field_double(model, k_time, &time) || !read_inputs(sd, &cmd, &wind)) goto python;
    p = (const double *)PyBytes_AsString(kbuf);
    /* from here on the model changes: an error is raised (as the Python step raises it), not retried */
    ok = PyObject_SetAttr(model, k_wind_m, wind) == 0
        && advance(model, p, n, h, cmd, sd, PyFloat_AsDouble(PyTuple_GetItem(wind, 0)),
                   PyFloat_AsDouble(PyTuple_GetItem(wind, 1)), &v)
        && set_field_double(model, k_time, time + dt) && publish(sd, p, &v);
    release_view(&v);
    Py_DECREF(sub); Py_DECREF(kbuf); Py_DECREF(wind);
    if (!ok) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_RuntimeError, "_dynamics_ext.step: unexpected model state");
        return NULL;
    }
    Py_RETURN_TRUE;
python:
    PyErr_Clear();
    Py_XDECREF(sub); Py_XDECREF(kbuf); Py_XDECREF(wind);
    Py_RETURN_FALSE;
}

/* ------------------------------------------------------------------ the geodetic outputs (lat, lon, alt) */

/* WGS84, as uavsim/geodesy.py derives its constants */
static const double WGS84_A = 6378137.0;
static double wgs84_b, wgs84_e2, wgs84_ep2;

/* Python's x ** 3.0 for a float x: CPython's float power calls libm's pow on |x| and negates for a negative x */
static double py_cube(double x)
{
    if (x < 0.0) return -pow(-x, 3.0);
    return x == 1.0 ? 1.0 : pow(x, 3.0);
}

/* EnuFrame.to_geodetic(e, n, u) of uavsim/geodesy.py, operation by operation in the same order, on the frame's
 * constants; p = math.hypot(x, y) is Python's own (0: a Python error, or constants that are not 7 exact floats) */
static int to_geodetic(PyObject *frame, double e, double n, double u, double out[3])
{
    const double a = WGS84_A, b = wgs84_b, e2 = wgs84_e2, ep2 = wgs84_ep2;
    double c7[7], x, y, z, p, lon, theta, st, ct, lat, s, c;
    PyObject *xo, *yo, *consts = PyObject_GetAttr(frame, k_constants);
    int ok = consts != NULL && PyTuple_Check(consts) && PyTuple_Size(consts) == 7;
    for (int j = 0; ok && j < 7; j++) {
        PyObject *v = PyTuple_GetItem(consts, j);
        ok = PyFloat_CheckExact(v);
        if (ok) c7[j] = PyFloat_AsDouble(v);
    }
    Py_XDECREF(consts);
    if (!ok) return 0;
    {
        const double x0 = c7[0], y0 = c7[1], z0 = c7[2], sp = c7[3], cp = c7[4], sl = c7[5], cl = c7[6];
        x = x0 + (-sl * e - sp * cl * n + cp * cl * u);
        y = y0 + (cl * e - sp * sl * n + cp * sl * u);
        z = z0 + (cp * n + sp * u);
    }
    xo = PyFloat_FromDouble(x);
    yo = PyFloat_FromDouble(y);
    ok = xo != NULL && yo != NULL && py_hypot(xo, yo, &p);
    Py_XDECREF(xo); Py_XDECREF(yo);
    if (!ok) return 0;
    lon = atan2(y, x);
    theta = atan2(z * a, p * b);
    st = sin(theta); ct = cos(theta);
    lat = atan2(z + ep2 * b * py_cube(st), p - e2 * a * py_cube(ct));
    for (int k = 0; k < 2; k++) {
        s = sin(lat);
        lat = atan2(z + e2 * (a / sqrt(1.0 - e2 * s * s)) * s, p);
    }
    s = sin(lat); c = cos(lat);
    out[0] = (180.0 / Py_MATH_PI) * lat;      /* math.degrees */
    out[1] = (180.0 / Py_MATH_PI) * lon;
    out[2] = p * c + z * s - a * sqrt(1.0 - e2 * s * s);
    return 1;
}

/* UavDynamics.geodetic(shell)[j] (the shell's lat, lon or alt): the conversion of (x, y, z), cached in the shell's
 * geodetic_key and geodetic_value as the Python method caches it; before initialisation (no frame yet) and for
 * positions that are not exact floats, the Python method itself */
static PyObject *geodetic_item(PyObject *shell, Py_ssize_t j)
{
    PyObject *frame = NULL, *x = NULL, *y = NULL, *z = NULL, *key = NULL, *old = NULL, *geo = NULL, *r = NULL;
    double out[3];
    int changed;
    /* one look-up at a time: a second look-up with the first one's AttributeError pending may clear it (its
       own suppressed look-ups do), and NULL would then go back without an exception (SystemError in hasattr
       while pythonfmu registers ``lat`` on a shell whose frame is not set yet) */
    if ((frame = PyObject_GetAttr(shell, k_frame)) == NULL || (x = PyObject_GetAttr(shell, k_x)) == NULL ||
        (y = PyObject_GetAttr(shell, k_y)) == NULL || (z = PyObject_GetAttr(shell, k_z)) == NULL) goto done;
    if (frame == Py_None || !PyFloat_CheckExact(x) || !PyFloat_CheckExact(y) || !PyFloat_CheckExact(z))
        goto python;
    if ((key = PyTuple_Pack(3, x, y, z)) == NULL || (old = PyObject_GetAttr(shell, k_geo_key)) == NULL) goto done;
    changed = PyObject_RichCompareBool(key, old, Py_NE);      /* key != self.geodetic_key */
    if (changed < 0) goto done;
    if (!changed) {
        if ((geo = PyObject_GetAttr(shell, k_geo)) == NULL) goto done;
        if (!PyTuple_Check(geo) || PyTuple_Size(geo) != 3) goto python;
        r = PyTuple_GetItem(geo, j);
        Py_XINCREF(r);
        goto done;
    }
    if (!to_geodetic(frame, PyFloat_AsDouble(x), PyFloat_AsDouble(y), PyFloat_AsDouble(z), out)) {
        if (PyErr_Occurred()) goto done;
        goto python;
    }
    geo = Py_BuildValue("(ddd)", out[0], out[1], out[2]);
    if (geo != NULL && PyObject_SetAttr(shell, k_geo, geo) == 0 && PyObject_SetAttr(shell, k_geo_key, key) == 0) {
        r = PyTuple_GetItem(geo, j);
        Py_XINCREF(r);
    }
    goto done;
python:
    {
        PyObject *t = PyObject_CallMethodObjArgs(shell, str_geodetic, NULL);
        if (t != NULL) r = PySequence_GetItem(t, j);
        Py_XDECREF(t);
    }
done:
    Py_XDECREF(frame); Py_XDECREF(x); Py_XDECREF(y); Py_XDECREF(z);
    Py_XDECREF(key); Py_XDECREF(old); Py_XDECREF(geo);
    return r;
}

static PyObject *geo_lat(PyObject *module, PyObject *shell) { (void)module; return geodetic_item(shell, 0); }
static PyObject *geo_lon(PyObject *module, PyObject *shell) { (void)module; return geodetic_item(shell, 1); }
static PyObject *geo_alt(PyObject *module, PyObject *shell) { (void)module; return geodetic_item(shell, 2); }

static PyMethodDef methods[] = {
    {"step", step, METH_VARARGS,
     "step(model, variables, step_size) -> bool: UavDynamics.do_step on its Dynamics model and its variables; "
     "False: nothing done, run the Python step"},
    {"lat", geo_lat, METH_O, "lat(shell): the shell's lat, as its property computes it (uavsim.geodesy.EnuFrame)"},
    {"lon", geo_lon, METH_O, "lon(shell): the shell's lon, as its property computes it"},
    {"alt", geo_alt, METH_O, "alt(shell): the shell's alt, as its property computes it"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_dynamics_ext", NULL, -1, methods,
                                       NULL, NULL, NULL, NULL};

static int intern(PyObject **slot, const char *s)
{
    *slot = PyUnicode_InternFromString(s);
    return *slot != NULL;
}

PyMODINIT_FUNC PyInit__dynamics_ext(void)
{
    PyObject *math = PyImport_ImportModule("math");
    if (math == NULL) return NULL;
    hypot_fn = PyObject_GetAttrString(math, "hypot");
    Py_DECREF(math);
    if (hypot_fn == NULL) return NULL;
    if (!(intern(&str_goto, "goto") && intern(&str_hold, "hold") && intern(&str_run, "run_substeps")
          && intern(&str_touch_down, "touch_down")
          && intern(&k_cmd, "cmd") && intern(&k_sp[0], "sp_x") && intern(&k_sp[1], "sp_y")
          && intern(&k_sp[2], "sp_z") && intern(&k_wind[0], "wind_x") && intern(&k_wind[1], "wind_y")
          && intern(&k_wind[2], "wind_z") && intern(&k_x, "x") && intern(&k_y, "y") && intern(&k_z, "z")
          && intern(&k_vx, "vx") && intern(&k_vy, "vy") && intern(&k_vz, "vz") && intern(&k_airspeed, "airspeed")
          && intern(&k_groundspeed, "groundspeed") && intern(&k_tilt, "tilt") && intern(&k_phase, "phase")
          && intern(&k_ready, "ready") && intern(&k_sub, "substep_table") && intern(&k_kbuf, "step_constants")
          && intern(&k_pos, "pos") && intern(&k_vel, "vel") && intern(&k_vt, "vt") && intern(&k_vtz, "vtz")
          && intern(&k_integ, "integ") && intern(&k_hold, "hold") && intern(&k_hold_z, "hold_z")
          && intern(&k_mode, "mode") && intern(&k_a_cmd, "a_cmd") && intern(&k_wind_m, "wind")
          && intern(&k_preflight_elapsed, "preflight_elapsed") && intern(&k_time, "time")
          && intern(&str_geodetic, "geodetic") && intern(&k_frame, "enu_frame") && intern(&k_geo, "geodetic_value")
          && intern(&k_geo_key, "geodetic_key") && intern(&k_constants, "constants")))
        return NULL;
    {   /* geodesy.py: WGS84_F = 1.0 / 298.257223563, WGS84_B = WGS84_A * (1.0 - WGS84_F), ... */
        volatile double f = 1.0 / 298.257223563;
        wgs84_b = WGS84_A * (1.0 - f);
        wgs84_e2 = f * (2.0 - f);
        wgs84_ep2 = wgs84_e2 / (1.0 - wgs84_e2);
    }
    return PyModule_Create(&moduledef);
}

/* The whole FMU step of the UavDynamics shell in one call (uavsim/native.py; the Python twin is
 * fmu_sources/UavDynamics.py do_step -> uavsim.dynamics.Dynamics.step + Dynamics.outputs).
 *
 * step(shell_dict, step_size) reads the shell's inputs from its __dict__, advances the shell's Dynamics model
 * (its state stays in the model's Python attributes, as Dynamics._run leaves them, so FMU get/set state, the
 * properties and the Python twin see the same object) and writes the published outputs back into __dict__.
 * The flying sub-steps are uav_fly of kernels.c, the kernel Dynamics._run calls through ctypes; the rare
 * phases (lift-off, the sub-steps after a touch-down) go back to Dynamics._run.  It returns False without
 * changing anything when the Python code must do the whole step (no model yet, a step size not seen before,
 * a value it cannot convert: the Python code then raises the error it always raised).
 *
 * Bit-identity: the arithmetic is kernels.c's; the published speeds use Python's own math.hypot (not libm's
 * hypot: CPython rounds differently), called through the function object.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "kernels.c"

enum { PREFLIGHT = 0, ON_GROUND = 4 };   /* phases (LANDED is a state slot) */
enum { CMD_TAKEOFF = 1 };
/* Dynamics._kbuf: kernels.c's parameter slots, then these two (uavsim/dynamics.py _kernel_buffer) */
enum { K_PREFLIGHT_TIME = NPARAM, K_G, NKBUF };

static PyObject *hypot_fn;
static PyObject *str_goto, *str_hold, *str_run, *str_touch_down, *str_dict;
/* shell keys */
static PyObject *k_model, *k_cmd, *k_sp[3], *k_wind[3], *k_x, *k_y, *k_z, *k_vx, *k_vy, *k_vz, *k_airspeed,
    *k_groundspeed, *k_tilt, *k_phase, *k_ready;
/* model keys (k_phase and k_ready too) */
static PyObject *k_sub, *k_kbuf, *k_pos, *k_vel, *k_vt, *k_vtz, *k_integ, *k_hold, *k_hold_z, *k_mode, *k_a_cmd,
    *k_wind_m, *k_preflight_elapsed, *k_time;

/* ------------------------------------------------------------------ small helpers (0 / NULL: a Python error) */

/* d[key] borrowed, NULL when missing (PyDict_GetItem would also save and restore the error state: slower) */
static PyObject *lookup(PyObject *d, PyObject *key) { return PyDict_GetItemWithError(d, key); }

static int get_double(PyObject *d, PyObject *key, double *out)
{
    PyObject *v = lookup(d, key);
    if (v == NULL) return 0;
    *out = PyFloat_AsDouble(v);
    return !(*out == -1.0 && PyErr_Occurred());
}

static int get_long(PyObject *d, PyObject *key, long *out)
{
    PyObject *v = lookup(d, key);
    if (v == NULL || !PyLong_Check(v)) return 0;
    *out = PyLong_AsLong(v);
    return !(*out == -1 && PyErr_Occurred());
}

/* list d[key] of n numbers into out[0..n-1] */
static int get_list(PyObject *d, PyObject *key, double *out, Py_ssize_t n)
{
    PyObject *v = lookup(d, key);
    if (v == NULL || !PyList_Check(v) || PyList_Size(v) != n) return 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        out[i] = PyFloat_AsDouble(PyList_GetItem(v, i));
        if (out[i] == -1.0 && PyErr_Occurred()) return 0;
    }
    return 1;
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

/* d[key] = list of x[0..n-1]: the values replace those of the list d[key] has (as Dynamics._substep updates
 * its lists in place; a new list costs an allocation and the garbage collector's tracking) */
static int put_list(PyObject *d, PyObject *key, const double *x, Py_ssize_t n)
{
    PyObject *list = lookup(d, key);
    int fresh = list == NULL || !PyList_Check(list) || PyList_Size(list) != n;
    if (fresh && (list = PyList_New(n)) == NULL) return 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *f = PyFloat_FromDouble(x[i]);
        if (f == NULL) { if (fresh) Py_DECREF(list); return 0; }
        PyList_SetItem(list, i, f);
    }
    return fresh ? put(d, key, list) : 1;
}

/* float(obj), as a new reference */
static PyObject *as_float(PyObject *d, PyObject *key)
{
    PyObject *v = lookup(d, key);
    return v == NULL ? NULL : PyNumber_Float(v);
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

/* One pass of Dynamics._run's loop body through uav_fly: the state in and out of the model's attributes.
 * Returns the sub-step reached (-1: error) and sets *landed. */
static long fly(PyObject *md, const double *p, long i, long n, double h, long cmd, const double *sp,
                double wx, double wy, int *landed)
{
    double s[NSTATE], pos[3], vel[3], vt[2], integ[2], hold[2];
    long phase;
    PyObject *mode = lookup(md, k_mode);
    int goto_;
    if (mode == NULL || !get_list(md, k_pos, pos, 3) || !get_list(md, k_vel, vel, 3) || !get_list(md, k_vt, vt, 2)
        || !get_list(md, k_integ, integ, 2) || !get_list(md, k_hold, hold, 2) || !get_double(md, k_vtz, &s[VTZ])
        || !get_double(md, k_hold_z, &s[HOLDZ]) || !get_long(md, k_phase, &phase))
        return -1;
    goto_ = PyObject_RichCompareBool(mode, str_goto, Py_EQ);
    if (goto_ < 0) return -1;
    s[PX] = pos[0]; s[PY] = pos[1]; s[PZ] = pos[2]; s[VX] = vel[0]; s[VY] = vel[1];
    s[VTX] = vt[0]; s[VTY] = vt[1]; s[IX] = integ[0]; s[IY] = integ[1]; s[AX] = 0.0; s[AY] = 0.0;
    s[HX] = hold[0]; s[HY] = hold[1]; s[PHASE] = (double)phase; s[MODE] = goto_ ? 1.0 : 0.0; s[LANDED] = 0.0;
    s[I] = (double)i; s[N] = (double)n; s[H] = h; s[CMD] = (double)cmd;
    s[SPX] = sp[0]; s[SPY] = sp[1]; s[SPZ] = sp[2]; s[WX] = wx; s[WY] = wy;
    i = uav_fly(s, p);
    {
        const double newpos[3] = {s[PX], s[PY], s[PZ]}, newvel[3] = {s[VX], s[VY], s[VTZ]};
        const double newvt[2] = {s[VTX], s[VTY]}, newinteg[2] = {s[IX], s[IY]}, acmd[2] = {s[AX], s[AY]};
        const double newhold[2] = {s[HX], s[HY]};
        PyObject *m = s[MODE] != 0.0 ? str_goto : str_hold;
        Py_INCREF(m);
        if (!put_list(md, k_pos, newpos, 3) || !put_list(md, k_vel, newvel, 3) || !put_list(md, k_vt, newvt, 2)
            || !put_double(md, k_vtz, s[VTZ]) || !put_list(md, k_integ, newinteg, 2)
            || !put_list(md, k_a_cmd, acmd, 2) || !put(md, k_phase, PyLong_FromLong((long)s[PHASE]))
            || !put(md, k_mode, m) || !put_list(md, k_hold, newhold, 2) || !put_double(md, k_hold_z, s[HOLDZ]))
            return -1;
    }
    *landed = s[LANDED] != 0.0;
    return i;
}

/* Dynamics.step's phase dispatch, once the inputs are read (1 done, 0 error) */
static int advance(PyObject *model, PyObject *md, const double *p, long n, double h, long cmd, PyObject *sp,
                   double wx, double wy)
{
    long phase;
    if (!get_long(md, k_phase, &phase)) return 0;
    if (phase == ON_GROUND && cmd != CMD_TAKEOFF) return 1;            /* on the ground: nothing changes */
    if (phase == PREFLIGHT && cmd != CMD_TAKEOFF && cmd != CMD_GOTO) {  /* only the preflight clock runs */
        const double pt = p[K_PREFLIGHT_TIME] - 1e-9;
        double elapsed;
        int ready = 0;
        if (!get_double(md, k_preflight_elapsed, &elapsed)) return 0;
        for (long j = 0; j < n; j++) {
            elapsed += h;
            if (elapsed >= pt) ready = 1;
        }
        if (!put_double(md, k_preflight_elapsed, elapsed)) return 0;
        if (ready) { Py_INCREF(Py_True); if (!put(md, k_ready, Py_True)) return 0; }
        return 1;
    }
    if (phase != PREFLIGHT && phase != ON_GROUND) {
        double spd[3];
        int landed = 0;
        long i;
        for (int j = 0; j < 3; j++) spd[j] = PyFloat_AsDouble(PyTuple_GetItem(sp, j));
        i = fly(md, p, 0, n, h, cmd, spd, wx, wy, &landed);
        if (i < 0) return 0;
        if (landed) {
            PyObject *r = PyObject_CallMethodObjArgs(model, str_touch_down, NULL);
            if (r == NULL) return 0;
            Py_DECREF(r);
        }
        if (i >= n) return 1;
        /* touched down before the end of the step: the rest (on the ground) in Python, from sub-step i */
        {
            PyObject *r, *ni = PyLong_FromLong(n), *hi = PyFloat_FromDouble(h), *ci = PyLong_FromLong(cmd),
                         *ii = PyLong_FromLong(i);
            r = (ni && hi && ci && ii) ? PyObject_CallMethodObjArgs(model, str_run, ni, hi, ci, sp, ii, NULL) : NULL;
            Py_XDECREF(ni); Py_XDECREF(hi); Py_XDECREF(ci); Py_XDECREF(ii);
            if (r == NULL) return 0;
            Py_DECREF(r);
            return 1;
        }
    }
    /* lift-off (from preflight or landed): Dynamics._run, the reference code for it */
    {
        PyObject *r, *ni = PyLong_FromLong(n), *hi = PyFloat_FromDouble(h), *ci = PyLong_FromLong(cmd);
        r = (ni && hi && ci) ? PyObject_CallMethodObjArgs(model, str_run, ni, hi, ci, sp, NULL) : NULL;
        Py_XDECREF(ni); Py_XDECREF(hi); Py_XDECREF(ci);
        if (r == NULL) return 0;
        Py_DECREF(r);
        return 1;
    }
}

/* Dynamics.outputs() into the shell's attributes, as UavDynamics._publish assigns them (1 done, 0 error) */
static int publish(PyObject *sd, PyObject *md, const double *p)
{
    PyObject *pos = lookup(md, k_pos), *vel = lookup(md, k_vel), *a = lookup(md, k_a_cmd);
    PyObject *w = lookup(md, k_wind_m), *phase_o = lookup(md, k_phase);
    PyObject *ready_o = lookup(md, k_ready), *gx_o, *gy_o, *ax_o, *ay_o, *phase_i, *ready_i;
    double v0, v1, w0, w1, air, ground, amag;
    long phase;
    int ok, push = p[PUSH] != 0.0;
    if (pos == NULL || vel == NULL || a == NULL || w == NULL || phase_o == NULL || ready_o == NULL
        || !PyList_Check(pos) || PyList_Size(pos) != 3 || !PyList_Check(vel) || PyList_Size(vel) != 3
        || !PyList_Check(a) || PyList_Size(a) != 2 || !PyTuple_Check(w) || PyTuple_Size(w) != 3
        || !PyLong_Check(phase_o))
        return 0;
    v0 = PyFloat_AsDouble(PyList_GetItem(vel, 0));
    v1 = PyFloat_AsDouble(PyList_GetItem(vel, 1));
    w0 = PyFloat_AsDouble(PyTuple_GetItem(w, 0));
    w1 = PyFloat_AsDouble(PyTuple_GetItem(w, 1));
    phase = PyLong_AsLong(phase_o);
    if (PyErr_Occurred()) return 0;
    if (push && (phase == TAKEOFF || phase == FLY || phase == LAND)) {
        gx_o = PyFloat_FromDouble(v0 + w0);
        gy_o = PyFloat_FromDouble(v1 + w1);
    } else {
        gx_o = PyList_GetItem(vel, 0); Py_INCREF(gx_o);
        gy_o = PyList_GetItem(vel, 1); Py_INCREF(gy_o);
    }
    if (gx_o == NULL || gy_o == NULL) { Py_XDECREF(gx_o); Py_XDECREF(gy_o); return 0; }
    if (push) {
        ok = py_hypot(PyList_GetItem(vel, 0), PyList_GetItem(vel, 1), &air);
    } else {
        PyObject *dx = PyFloat_FromDouble(v0 - w0), *dy = PyFloat_FromDouble(v1 - w1);
        ok = dx != NULL && dy != NULL && py_hypot(dx, dy, &air);
        Py_XDECREF(dx); Py_XDECREF(dy);
    }
    ax_o = PyList_GetItem(a, 0);
    ay_o = PyList_GetItem(a, 1);
    ok = ok && py_hypot(gx_o, gy_o, &ground) && py_hypot(ax_o, ay_o, &amag);
    if (!ok) { Py_DECREF(gx_o); Py_DECREF(gy_o); return 0; }
    phase_i = PyNumber_Long(phase_o);
    ready_i = PyNumber_Long(ready_o);
    for (int j = 0; j < 3; j++) Py_INCREF(PyList_GetItem(pos, j));
    Py_INCREF(PyList_GetItem(vel, 2));
    /* math.degrees(x) is x * (180 / pi) */
    return put(sd, k_x, PyList_GetItem(pos, 0)) && put(sd, k_y, PyList_GetItem(pos, 1))
        && put(sd, k_z, PyList_GetItem(pos, 2)) && put(sd, k_vx, gx_o) && put(sd, k_vy, gy_o)
        && put(sd, k_vz, PyList_GetItem(vel, 2)) && put_double(sd, k_airspeed, air)
        && put_double(sd, k_groundspeed, ground)
        && put_double(sd, k_tilt, (180.0 / Py_MATH_PI) * atan2(amag, p[K_G]))
        && put(sd, k_phase, phase_i) && put(sd, k_ready, ready_i);
}

/* the inputs of Dynamics.step as UavDynamics.do_step passes them; 0: the Python code must do the step */
static int read_inputs(PyObject *sd, long *cmd, PyObject **sp, PyObject **wind)
{
    PyObject *c = lookup(sd, k_cmd), *ci;
    *sp = *wind = NULL;
    if (c == NULL || (ci = PyNumber_Long(c)) == NULL) return 0;
    *cmd = PyLong_AsLong(ci);
    Py_DECREF(ci);
    if (*cmd == -1 && PyErr_Occurred()) return 0;
    *sp = PyTuple_New(3);
    *wind = PyTuple_New(3);
    if (*sp == NULL || *wind == NULL) return 0;
    for (int j = 0; j < 3; j++) {
        PyObject *s = as_float(sd, k_sp[j]), *w = as_float(sd, k_wind[j]);
        if (s) PyTuple_SetItem(*sp, j, s);
        if (w) PyTuple_SetItem(*wind, j, w);
        if (s == NULL || w == NULL) return 0;
    }
    return 1;
}

static PyObject *step(PyObject *module, PyObject *args)
{
    PyObject *sd, *dt_o, *model, *md = NULL, *nh, *kbuf, *sp = NULL, *wind = NULL;
    const double *p;
    double dt, h, time;
    long n, cmd;
    int ok = 0;
    (void)module;
    if (PyTuple_Size(args) != 2 || !PyDict_Check(sd = PyTuple_GetItem(args, 0))) {
        PyErr_SetString(PyExc_TypeError, "step(shell_dict, step_size)");
        return NULL;
    }
    dt_o = PyTuple_GetItem(args, 1);
    model = lookup(sd, k_model);
    dt = PyFloat_AsDouble(dt_o);
    if (model == NULL || model == Py_None || (dt == -1.0 && PyErr_Occurred()) || !(dt > 0.0))
        goto python;
    md = PyObject_GetAttr(model, str_dict);
    if (md == NULL || !PyDict_Check(md)) goto python;
    {   /* the model's cached sub-division of this step size (a new one: the Python code computes it) */
        PyObject *sub = lookup(md, k_sub);
        nh = sub != NULL && PyDict_Check(sub) ? lookup(sub, dt_o) : NULL;
    }
    kbuf = lookup(md, k_kbuf);
    if (nh == NULL || !PyTuple_Check(nh) || PyTuple_Size(nh) != 2 || kbuf == NULL || !PyBytes_Check(kbuf)
        || PyBytes_Size(kbuf) != NKBUF * (Py_ssize_t)sizeof(double))
        goto python;
    n = PyLong_AsLong(PyTuple_GetItem(nh, 0));
    h = PyFloat_AsDouble(PyTuple_GetItem(nh, 1));
    if (PyErr_Occurred() || !get_double(md, k_time, &time) || !read_inputs(sd, &cmd, &sp, &wind)) goto python;
    p = (const double *)PyBytes_AsString(kbuf);
    /* from here on the model changes: an error is raised, not retried in Python */
    Py_INCREF(wind);
    if (!put(md, k_wind_m, wind)) goto done;
    if (!advance(model, md, p, n, h, cmd, sp, PyFloat_AsDouble(PyTuple_GetItem(wind, 0)),
                 PyFloat_AsDouble(PyTuple_GetItem(wind, 1))))
        goto done;
    if (!get_double(md, k_time, &time) || !put_double(md, k_time, time + dt)) goto done;
    ok = publish(sd, md, p);
done:
    Py_XDECREF(md); Py_XDECREF(sp); Py_XDECREF(wind);
    if (!ok) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_RuntimeError, "_dynamics_ext.step: unexpected model state");
        return NULL;
    }
    Py_RETURN_TRUE;
python:
    PyErr_Clear();
    Py_XDECREF(md); Py_XDECREF(sp); Py_XDECREF(wind);
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"step", step, METH_VARARGS,
     "step(shell_dict, step_size) -> bool: UavDynamics.do_step on the shell's __dict__; False: nothing done, "
     "run the Python step"},
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
    if (!(intern(&str_goto, "goto") && intern(&str_hold, "hold") && intern(&str_run, "_run")
          && intern(&str_touch_down, "_touch_down") && intern(&str_dict, "__dict__") && intern(&k_model, "_model")
          && intern(&k_cmd, "cmd") && intern(&k_sp[0], "sp_x") && intern(&k_sp[1], "sp_y")
          && intern(&k_sp[2], "sp_z") && intern(&k_wind[0], "wind_x") && intern(&k_wind[1], "wind_y")
          && intern(&k_wind[2], "wind_z") && intern(&k_x, "x") && intern(&k_y, "y") && intern(&k_z, "z")
          && intern(&k_vx, "vx") && intern(&k_vy, "vy") && intern(&k_vz, "vz") && intern(&k_airspeed, "airspeed")
          && intern(&k_groundspeed, "groundspeed") && intern(&k_tilt, "tilt") && intern(&k_phase, "phase")
          && intern(&k_ready, "ready") && intern(&k_sub, "_sub") && intern(&k_kbuf, "_kbuf")
          && intern(&k_pos, "pos") && intern(&k_vel, "vel") && intern(&k_vt, "vt") && intern(&k_vtz, "vtz")
          && intern(&k_integ, "integ") && intern(&k_hold, "hold") && intern(&k_hold_z, "hold_z")
          && intern(&k_mode, "mode") && intern(&k_a_cmd, "a_cmd") && intern(&k_wind_m, "wind")
          && intern(&k_preflight_elapsed, "preflight_elapsed") && intern(&k_time, "time")))
        return NULL;
    return PyModule_Create(&moduledef);
}

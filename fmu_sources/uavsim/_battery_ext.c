/* The whole FMU step of the UavBattery shell in one call (uavsim/native.py; the Python twin is
 * fmu_sources/UavBattery.py do_step -> uavsim.battery.Battery.step_outputs).
 *
 * step(shell_dict, step_size) reads airspeed, vz and phase from the shell's __dict__, runs uav_battery_step of
 * kernels.c (the kernel step_outputs calls through ctypes) on the shell's Battery model, whose state stays in its
 * Python attributes (FMU get/set state and the Python twin see the same object), and writes the published
 * outputs back into __dict__.  It returns False without changing anything when the Python code must do the
 * step (no model, a step size not seen before, an input it cannot convert: the Python code raises then).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "kernels.c"

static PyObject *str_dict, *k_model, *k_airspeed, *k_vz, *k_phase, *k_soc, *k_consumed, *k_voltage, *k_current,
    *k_power, *k_energy_used, *k_depleted, *k_sub, *k_kbuf, *k_charge_used, *k_overload;

static int put(PyObject *d, PyObject *key, PyObject *value)
{
    int rc;
    if (value == NULL) return 0;
    rc = PyDict_SetItem(d, key, value);
    Py_DECREF(value);
    return rc == 0;
}

/* float(d[key]) as a double (0: a Python error) */
static int input_double(PyObject *d, PyObject *key, double *out)
{
    PyObject *v = PyDict_GetItemWithError(d, key), *f;
    if (v == NULL || (f = PyNumber_Float(v)) == NULL) return 0;
    *out = PyFloat_AsDouble(f);
    Py_DECREF(f);
    return 1;
}

/* int(d[key]) in (1, 2, 3): the motors run in takeoff, fly and land (-1: a Python error) */
static int motors_on(PyObject *d, PyObject *key)
{
    PyObject *v = PyDict_GetItemWithError(d, key), *i;
    long phase;
    int overflow;
    if (v == NULL || (i = PyNumber_Long(v)) == NULL) return -1;
    phase = PyLong_AsLongAndOverflow(i, &overflow);
    Py_DECREF(i);
    if (phase == -1 && PyErr_Occurred()) return -1;
    return !overflow && phase >= 1 && phase <= 3;
}

/* Battery._kbuf holds the power slots, the battery slots and the two OCV tables their length says */
static int parameters_fit(PyObject *kbuf)
{
    const Py_ssize_t size = PyBytes_Size(kbuf) / (Py_ssize_t)sizeof(double);
    const double *p = (const double *)PyBytes_AsString(kbuf);
    return size > WPOWER + BM && p[WPOWER + BM] >= 1.0 && size == WPOWER + BTABLE + 2 * (Py_ssize_t)p[WPOWER + BM];
}

static PyObject *step(PyObject *module, PyObject *args)
{
    PyObject *sd, *dt_o, *model, *md = NULL, *sub, *nh, *kbuf, *cur_o, *volt_o, *pw_o, *e_o;
    double dt, s[BSTEP];
    int motors, ok;
    (void)module;
    if (PyTuple_Size(args) != 2 || !PyDict_Check(sd = PyTuple_GetItem(args, 0))) {
        PyErr_SetString(PyExc_TypeError, "step(shell_dict, step_size)");
        return NULL;
    }
    dt_o = PyTuple_GetItem(args, 1);
    model = PyDict_GetItemWithError(sd, k_model);
    dt = PyFloat_AsDouble(dt_o);
    if (model == NULL || model == Py_None || (dt == -1.0 && PyErr_Occurred()) || dt != dt) goto python;
    if (dt <= 0.0) Py_RETURN_TRUE;       /* step_outputs: nothing changes, nothing is published */
    md = PyObject_GetAttr(model, str_dict);
    if (md == NULL || !PyDict_Check(md)) goto python;
    sub = PyDict_GetItemWithError(md, k_sub);
    nh = sub != NULL && PyDict_Check(sub) ? PyDict_GetItemWithError(sub, dt_o) : NULL;
    kbuf = PyDict_GetItemWithError(md, k_kbuf);
    if (nh == NULL || !PyTuple_Check(nh) || PyTuple_Size(nh) != 2 || kbuf == NULL || !PyBytes_Check(kbuf)
        || !parameters_fit(kbuf))
        goto python;
    {
        PyObject *q = PyDict_GetItemWithError(md, k_charge_used), *e = PyDict_GetItemWithError(md, k_energy_used);
        if (q == NULL || e == NULL) goto python;
        s[BQ] = PyFloat_AsDouble(q);
        s[BE] = PyFloat_AsDouble(e);
    }
    s[BN] = (double)PyLong_AsLong(PyTuple_GetItem(nh, 0));
    s[BH] = PyFloat_AsDouble(PyTuple_GetItem(nh, 1));
    if (PyErr_Occurred() || !input_double(sd, k_airspeed, &s[BAIR]) || !input_double(sd, k_vz, &s[BVZ])
        || (motors = motors_on(sd, k_phase)) < 0)
        goto python;
    s[BCUR] = s[BOVER] = s[BVOLT] = s[BPOW] = s[BDEMAND] = s[BCONS] = s[BSOC] = s[BDEPL] = 0.0;
    s[BMOTORS] = motors ? 1.0 : 0.0;
    uav_battery_step(s, (const double *)PyBytes_AsString(kbuf));
    /* Battery.step_outputs' assignments, then UavBattery.do_step's (the same float objects in both) */
    cur_o = PyFloat_FromDouble(s[BCUR]);
    volt_o = PyFloat_FromDouble(s[BVOLT]);
    pw_o = PyFloat_FromDouble(s[BPOW]);
    e_o = PyFloat_FromDouble(s[BE]);
    ok = cur_o && volt_o && pw_o && e_o && put(md, k_charge_used, PyFloat_FromDouble(s[BQ]))
        && PyDict_SetItem(md, k_energy_used, e_o) == 0 && PyDict_SetItem(md, k_current, cur_o) == 0
        && PyDict_SetItem(md, k_overload, s[BOVER] != 0.0 ? Py_True : Py_False) == 0
        && PyDict_SetItem(md, k_voltage, volt_o) == 0 && PyDict_SetItem(md, k_power, pw_o) == 0
        && put(sd, k_soc, PyFloat_FromDouble(s[BSOC])) && put(sd, k_consumed, PyFloat_FromDouble(s[BCONS]))
        && PyDict_SetItem(sd, k_voltage, volt_o) == 0 && PyDict_SetItem(sd, k_current, cur_o) == 0
        && PyDict_SetItem(sd, k_power, pw_o) == 0 && PyDict_SetItem(sd, k_energy_used, e_o) == 0
        && put(sd, k_depleted, PyLong_FromLong(s[BDEPL] != 0.0));
    Py_XDECREF(cur_o); Py_XDECREF(volt_o); Py_XDECREF(pw_o); Py_XDECREF(e_o);
    Py_DECREF(md);
    if (!ok) return NULL;
    Py_RETURN_TRUE;
python:
    PyErr_Clear();
    Py_XDECREF(md);
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"step", step, METH_VARARGS,
     "step(shell_dict, step_size) -> bool: UavBattery.do_step on the shell's __dict__; False: nothing done, "
     "run the Python step"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_battery_ext", NULL, -1, methods,
                                       NULL, NULL, NULL, NULL};

static int intern(PyObject **slot, const char *s)
{
    *slot = PyUnicode_InternFromString(s);
    return *slot != NULL;
}

PyMODINIT_FUNC PyInit__battery_ext(void)
{
    if (!(intern(&str_dict, "__dict__") && intern(&k_model, "_model") && intern(&k_airspeed, "airspeed")
          && intern(&k_vz, "vz") && intern(&k_phase, "phase") && intern(&k_soc, "soc")
          && intern(&k_consumed, "consumed") && intern(&k_voltage, "voltage") && intern(&k_current, "current")
          && intern(&k_power, "power") && intern(&k_energy_used, "energy_used") && intern(&k_depleted, "depleted")
          && intern(&k_sub, "_sub") && intern(&k_kbuf, "_kbuf") && intern(&k_charge_used, "charge_used")
          && intern(&k_overload, "overload")))
        return NULL;
    return PyModule_Create(&moduledef);
}

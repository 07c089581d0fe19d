/* The UavBattery FMU's step in C: the accelerator of the shell's Python step (fmu_sources/UavBattery.py do_step ->
 * uavsim.battery.Battery.step_outputs), declared in uavsim/accelerators.py and checked against it by the
 * accelerator harness (tests/accelerators/).
 *
 * step(model, variables, step_size) runs uav_battery_step of kernels.c (the loop step_outputs runs) on the
 * Battery ``model`` and publishes the outputs.  What it reads and writes, all public:
 * - model: the Battery's fields, got and set by their names: step_constants (its parameters as native doubles,
 *   kernels.c's power then battery slots), substep_table (step size -> (sub-steps, sub-step)), charge_used,
 *   energy_used, current, overload, voltage, power;
 * - variables: the FMU's variables by their modelDescription names (the shell's variable values): the inputs
 *   airspeed, vz, phase and the outputs soc, consumed, voltage, current, power, energy_used, depleted.
 * It returns False without changing anything when the Python code must do the step (no model, a step size not
 * seen before, an input it cannot convert: the Python code raises then).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "kernels.c"

static PyObject *k_airspeed, *k_vz, *k_phase, *k_soc, *k_consumed, *k_voltage, *k_current,
    *k_power, *k_energy_used, *k_depleted, *k_sub, *k_kbuf, *k_charge_used, *k_overload;

/* model.name as a double (0: missing or not a number, the error cleared by the caller) */
static int field_double(PyObject *model, PyObject *name, double *out)
{
    PyObject *v = PyObject_GetAttr(model, name);
    if (v == NULL) return 0;
    *out = PyFloat_AsDouble(v);
    Py_DECREF(v);
    return !(*out == -1.0 && PyErr_Occurred());
}

/* model.name = value, stealing the reference to value */
static int set_field(PyObject *model, PyObject *name, PyObject *value)
{
    int rc;
    if (value == NULL) return 0;
    rc = PyObject_SetAttr(model, name, value);
    Py_DECREF(value);
    return rc == 0;
}

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

/* Battery.step_constants holds the power slots, the battery slots and the two OCV tables their length says */
static int parameters_fit(PyObject *kbuf)
{
    const Py_ssize_t size = PyBytes_Size(kbuf) / (Py_ssize_t)sizeof(double);
    const double *p = (const double *)PyBytes_AsString(kbuf);
    return size > WPOWER + BM && p[WPOWER + BM] >= 1.0 && size == WPOWER + BTABLE + 2 * (Py_ssize_t)p[WPOWER + BM];
}

static PyObject *step(PyObject *module, PyObject *args)
{
    PyObject *model, *sd, *dt_o, *sub = NULL, *nh, *kbuf = NULL, *cur_o, *volt_o, *pw_o, *e_o;
    double dt, s[BSTEP];
    int motors, ok;
    (void)module;
    if (PyTuple_Size(args) != 3 || !PyDict_Check(sd = PyTuple_GetItem(args, 1))) {
        PyErr_SetString(PyExc_TypeError, "step(model, variables, step_size)");
        return NULL;
    }
    model = PyTuple_GetItem(args, 0);
    dt_o = PyTuple_GetItem(args, 2);
    dt = PyFloat_AsDouble(dt_o);
    if (model == Py_None || (dt == -1.0 && PyErr_Occurred()) || dt != dt) goto python;
    if (dt <= 0.0) Py_RETURN_TRUE;       /* step_outputs: nothing changes, nothing is published */
    if ((sub = PyObject_GetAttr(model, k_sub)) == NULL || (kbuf = PyObject_GetAttr(model, k_kbuf)) == NULL)
        goto python;
    nh = PyDict_Check(sub) ? PyDict_GetItemWithError(sub, dt_o) : NULL;
    if (nh == NULL || !PyTuple_Check(nh) || PyTuple_Size(nh) != 2 || !PyBytes_Check(kbuf) || !parameters_fit(kbuf)
        || !field_double(model, k_charge_used, &s[BQ]) || !field_double(model, k_energy_used, &s[BE]))
        goto python;
    s[BN] = (double)PyLong_AsLong(PyTuple_GetItem(nh, 0));
    s[BH] = PyFloat_AsDouble(PyTuple_GetItem(nh, 1));
    if (PyErr_Occurred() || !input_double(sd, k_airspeed, &s[BAIR]) || !input_double(sd, k_vz, &s[BVZ])
        || (motors = motors_on(sd, k_phase)) < 0)
        goto python;
    s[BCUR] = s[BOVER] = s[BVOLT] = s[BPOW] = s[BDEMAND] = s[BCONS] = s[BSOC] = s[BDEPL] = 0.0;
    s[BMOTORS] = motors ? 1.0 : 0.0;
    uav_battery_step(s, (const double *)PyBytes_AsString(kbuf));
    Py_DECREF(sub);
    Py_DECREF(kbuf);
    /* Battery.step_outputs' assignments, then UavBattery.do_step's (the same float objects in both) */
    cur_o = PyFloat_FromDouble(s[BCUR]);
    volt_o = PyFloat_FromDouble(s[BVOLT]);
    pw_o = PyFloat_FromDouble(s[BPOW]);
    e_o = PyFloat_FromDouble(s[BE]);
    ok = cur_o && volt_o && pw_o && e_o && set_field(model, k_charge_used, PyFloat_FromDouble(s[BQ]))
        && PyObject_SetAttr(model, k_energy_used, e_o) == 0 && PyObject_SetAttr(model, k_current, cur_o) == 0
        && PyObject_SetAttr(model, k_overload, s[BOVER] != 0.0 ? Py_True : Py_False) == 0
        && PyObject_SetAttr(model, k_voltage, volt_o) == 0 && PyObject_SetAttr(model, k_power, pw_o) == 0
        && put(sd, k_soc, PyFloat_FromDouble(s[BSOC])) && put(sd, k_consumed, PyFloat_FromDouble(s[BCONS]))
        && PyDict_SetItem(sd, k_voltage, volt_o) == 0 && PyDict_SetItem(sd, k_current, cur_o) == 0
        && PyDict_SetItem(sd, k_power, pw_o) == 0 && PyDict_SetItem(sd, k_energy_used, e_o) == 0
        && put(sd, k_depleted, PyLong_FromLong(s[BDEPL] != 0.0));
    Py_XDECREF(cur_o); Py_XDECREF(volt_o); Py_XDECREF(pw_o); Py_XDECREF(e_o);
    if (!ok) return NULL;
    Py_RETURN_TRUE;
python:
    PyErr_Clear();
    Py_XDECREF(sub);
    Py_XDECREF(kbuf);
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"step", step, METH_VARARGS,
     "step(model, variables, step_size) -> bool: UavBattery.do_step on its Battery model and its variables; False: "
     "nothing done, run the Python step"},
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
    if (!(intern(&k_airspeed, "airspeed")
          && intern(&k_vz, "vz") && intern(&k_phase, "phase") && intern(&k_soc, "soc")
          && intern(&k_consumed, "consumed") && intern(&k_voltage, "voltage") && intern(&k_current, "current")
          && intern(&k_power, "power") && intern(&k_energy_used, "energy_used") && intern(&k_depleted, "depleted")
          && intern(&k_sub, "substep_table") && intern(&k_kbuf, "step_constants") && intern(&k_charge_used, "charge_used")
          && intern(&k_overload, "overload")))
        return NULL;
    return PyModule_Create(&moduledef);
}

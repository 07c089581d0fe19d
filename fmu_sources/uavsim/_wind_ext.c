/* The UavWind FMU's step in C: the accelerator of the shell's Python step (fmu_sources/UavWind.py do_step ->
 * _publish -> uavsim.wind.Wind.mean_over), declared in uavsim/accelerators.py and checked against it by the
 * accelerator harness (tests/accelerators/).
 *
 * step(model, variables, current_time, step_size) publishes the wind's mean over the coming step, as the shell's
 * _publish does with step_mean on: wind_x, wind_y, wind_z, wind_speed and wind_level.  What it reads and writes,
 * all public:
 * - model: the Wind's fields, got by their names: p (its WindParams: probability, decision_interval, duration,
 *   ramp, gusts, gust_length, gust_amplitude, turbulence), intervals (k -> Interval: level, speed, gust_start),
 *   occurs, drawn, ux, uy, and calm, the only field it sets (as mean_over sets it);
 * - variables: the FMU's variables by their modelDescription names (the shell's variable values): the parameter
 *   step_mean and the outputs wind_x, wind_y, wind_z, wind_speed, wind_level.
 * So FMU get/set state and the Python step see the same objects.
 *
 * Random numbers stay in Python: whenever the step needs an interval not drawn yet (an interval entered for the
 * first time, a calm window drawn ahead), and for the rare cases this file does not reproduce (the wind at a
 * point instead of the step mean, a step before time 0, Dryden turbulence, which keeps its own state in numpy
 * arrays), it returns False having changed nothing, and the Python code does the step.  Every number it reads
 * must be an exact float (or int where Python keeps an int); anything else is declined too.
 *
 * The arithmetic is mean_over's, expression by expression in the same order (compiled with -ffp-contract=off):
 * min/max keep Python's choice among equal values, math.floor and math.ceil of the same doubles, libm's cos as
 * math.cos, and the published speed (wx * wx + wy * wy) ** 0.5 is libm's pow, which Python's float power calls
 * for these operands (a finite non-negative base), not sqrt, which may round differently.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

#define RESOLUTION 0.05          /* Wind.mean_over's default sample spacing */
#define MAX_SAMPLES 200          /* mean_over's clip of the sample count */
#define CALM_AHEAD 16            /* Wind._calm_window's default ``ahead`` */
#define TWO_PI (2.0 * 3.141592653589793)      /* 2.0 * math.pi */
#define MAX_K 1e15               /* an interval index beyond this is left to Python (exact in a double) */

enum { DECLINED = 0, DONE = 1, FAILED = -1 };

static PyObject *k_step_mean, *k_p, *k_probability, *k_decision_interval, *k_duration, *k_ramp,
    *k_gusts, *k_gust_length, *k_gust_amplitude, *k_turbulence, *k_calm, *k_next_k, *k_occurs, *k_intervals, *k_ux,
    *k_uy, *k_level, *k_speed, *k_gust_start, *k_wind_x, *k_wind_y, *k_wind_z, *k_wind_speed, *k_wind_level;

static struct { PyObject **key; const char *name; } names[] = {
    {&k_step_mean, "step_mean"}, {&k_p, "p"},
    {&k_probability, "probability"}, {&k_decision_interval, "decision_interval"}, {&k_duration, "duration"},
    {&k_ramp, "ramp"}, {&k_gusts, "gusts"}, {&k_gust_length, "gust_length"}, {&k_gust_amplitude, "gust_amplitude"},
    {&k_turbulence, "turbulence"}, {&k_calm, "calm"}, {&k_next_k, "drawn"}, {&k_occurs, "occurs"},
    {&k_intervals, "intervals"}, {&k_ux, "ux"}, {&k_uy, "uy"}, {&k_level, "level"}, {&k_speed, "speed"},
    {&k_gust_start, "gust_start"}, {&k_wind_x, "wind_x"}, {&k_wind_y, "wind_y"}, {&k_wind_z, "wind_z"},
    {&k_wind_speed, "wind_speed"}, {&k_wind_level, "wind_level"}};

/* an exact float as a double (0: anything else, the step is left to Python) */
static int exact_double(PyObject *v, double *out)
{
    if (v == NULL || !PyFloat_CheckExact(v)) return 0;
    *out = PyFloat_AsDouble(v);
    return 1;
}

/* obj.name as a double (0: missing, or not an exact float) */
static int get_double(PyObject *obj, PyObject *name, double *out)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    int ok = exact_double(v, out);
    Py_XDECREF(v);
    return ok;
}

/* bool(obj.name) (-1: absent, or its truth raised) */
static int get_truth(PyObject *obj, PyObject *name)
{
    PyObject *v = PyObject_GetAttr(obj, name);
    int r = v == NULL ? -1 : PyObject_IsTrue(v);
    Py_XDECREF(v);
    return r;
}

/* The model's fields mean_over reads (occurs and intervals: references held until release_model). */
typedef struct {
    PyObject *occurs, *intervals;
    double di, D, ramp, tg_len, amp, ux, uy, lo, hi;
    long long next_k;
    int gust, turbulence;
} Model;

/* Wind.calm: the window (lo, hi) of calm steps */
static int calm_of(PyObject *model, double *lo, double *hi)
{
    PyObject *calm = PyObject_GetAttr(model, k_calm);
    int ok = calm != NULL && PyTuple_Check(calm) && PyTuple_Size(calm) == 2
        && exact_double(PyTuple_GetItem(calm, 0), lo) && exact_double(PyTuple_GetItem(calm, 1), hi);
    Py_XDECREF(calm);
    return ok;
}

static void release_model(Model *w)
{
    Py_CLEAR(w->occurs);
    Py_CLEAR(w->intervals);
}

/* the model's fields into *w (0: missing or of another type; release_model in any case) */
static int read_model(PyObject *model, PyObject *p, Model *w)
{
    PyObject *nk = PyObject_GetAttr(model, k_next_k);
    double duration, gust_length;
    int overflow = 1;
    w->occurs = PyObject_GetAttr(model, k_occurs);
    w->intervals = PyObject_GetAttr(model, k_intervals);
    if (nk != NULL && PyLong_CheckExact(nk)) w->next_k = PyLong_AsLongLongAndOverflow(nk, &overflow);
    Py_XDECREF(nk);
    if (!calm_of(model, &w->lo, &w->hi) || overflow || (w->next_k == -1 && PyErr_Occurred())
        || w->occurs == NULL || !PyList_Check(w->occurs) || w->intervals == NULL || !PyDict_Check(w->intervals)
        || PyList_Size(w->occurs) < w->next_k)
        return 0;
    if (!get_double(p, k_decision_interval, &w->di) || !get_double(p, k_duration, &duration)
        || !get_double(p, k_ramp, &w->ramp) || !get_double(p, k_gust_length, &gust_length)
        || !get_double(p, k_gust_amplitude, &w->amp) || !get_double(model, k_ux, &w->ux)
        || !get_double(model, k_uy, &w->uy))
        return 0;
    /* _episode_length: min(duration, decision_interval); tg_len = min(gust_length, D) (min keeps the first of equals) */
    w->D = w->di < duration ? w->di : duration;
    w->tg_len = w->D < gust_length ? w->D : gust_length;
    w->gust = get_truth(p, k_gusts);
    w->turbulence = get_truth(p, k_turbulence);
    if (w->gust < 0 || w->turbulence < 0) return 0;
    w->gust = w->gust && w->tg_len > 0.0;
    return 1;
}

/* occurs[k] of an interval drawn already (-1: not drawn, or not a truth value) */
static int occurs_at(const Model *w, long long k)
{
    if (k < 0 || k >= w->next_k) return -1;
    return PyObject_IsTrue(PyList_GetItem(w->occurs, (Py_ssize_t)k));
}

/* any(occurs[k0:k1 + 1]) (occurs[k0] when k0 == k1: the same); -1: an interval not drawn */
static int any_occurs(const Model *w, long long k0, long long k1)
{
    long long k;
    if (k1 >= w->next_k) return -1;
    for (k = k0; k <= k1; k++) {
        int o = occurs_at(w, k);
        if (o != 0) return o;
    }
    return 0;
}

/* Wind._calm_window(k0, k1): 0 when it would draw an interval (Python's job) */
static int calm_window(const Model *w, long long k0, long long k1, double *lo, double *hi)
{
    long long kb = k1;
    while (kb - k0 < CALM_AHEAD) {
        int o = occurs_at(w, kb + 1);
        if (o < 0) return 0;
        if (o) break;
        kb += 1;
    }
    *lo = ((double)k0 + 1e-6) * w->di;
    *hi = ((double)(kb + 1) - 1e-6) * w->di;
    return 1;
}

/* the level, speed and gust start drawn for interval k (0: missing, or not an int and exact floats) */
static int interval(const Model *w, long long k, long *level, double *speed, double *gust_start)
{
    PyObject *key = PyLong_FromLongLong(k), *iv, *lv;
    int overflow, ok;
    if (key == NULL) return 0;
    iv = PyDict_GetItemWithError(w->intervals, key);
    Py_DECREF(key);
    if (iv == NULL) return 0;
    lv = PyObject_GetAttr(iv, k_level);
    ok = lv != NULL && PyLong_CheckExact(lv);
    if (ok) {
        *level = PyLong_AsLongAndOverflow(lv, &overflow);
        ok = !overflow && !(*level == -1 && PyErr_Occurred());
    }
    Py_XDECREF(lv);
    if (ok) {
        PyObject *s = PyObject_GetAttr(iv, k_speed), *g = PyObject_GetAttr(iv, k_gust_start);
        ok = exact_double(s, speed) && exact_double(g, gust_start);
        Py_XDECREF(s);
        Py_XDECREF(g);
    }
    return ok;
}

/* floor(x) as an interval index (0: NaN or out of range) */
static int index_of(double x, long long *k)
{
    double f = floor(x);
    if (!(f > -MAX_K && f < MAX_K)) return 0;
    *k = (long long)f;
    return 1;
}

/* mean_over's loop over the m midpoint samples of at(t), in intervals drawn already (turbulence: declined) */
static int windy_mean(const Model *w, double t0, double h, long m, double out[3], long *level_out)
{
    double sx = 0.0, sy = 0.0, sz = 0.0, speed = 0.0, gust_start = 0.0;
    long level = 0, lv = 0, j;
    long long k_iv = -1;
    for (j = 0; j < m; j++) {
        double t = t0 + ((double)j + 0.5) * h / (double)m, tau, f, a, b, g, U, along, cross, up;
        long long k;
        int o;
        if (!index_of(t / w->di + 1e-12, &k) || (o = occurs_at(w, k)) < 0) return 0;
        if (!o) continue;
        if (k != k_iv) {
            if (!interval(w, k, &lv, &speed, &gust_start)) return 0;
            k_iv = k;
        }
        tau = t - (double)k * w->di;
        if (tau < 0.0 || tau >= w->D) continue;
        if (lv > level) level = lv;
        if (w->ramp > 0.0) {
            a = tau / w->ramp;
            b = (w->D - tau) / w->ramp;
            f = 1.0;
            if (a < f) f = a;
            if (b < f) f = b;
        } else {
            f = 1.0;
        }
        g = 0.0;
        if (f > g) g = f;
        U = speed * g;
        if (U <= 0.0) continue;
        if (w->turbulence) return 0;
        along = U;
        cross = 0.0;
        up = 0.0;
        f = U / speed;
        if (w->gust) {
            double s = tau - (w->D - w->tg_len) * gust_start;
            if (0.0 <= s && s <= w->tg_len)
                along += f * 0.5 * w->amp * speed * (1.0 - cos(TWO_PI * s / w->tg_len));
        }
        sx += along * w->ux - cross * w->uy;
        sy += along * w->uy + cross * w->ux;
        sz += up;
    }
    out[0] = sx / (double)m;
    out[1] = sy / (double)m;
    out[2] = sz / (double)m;
    *level_out = level;
    return 1;
}

/* mean_over's first exits, calm window included: 1 when the step lies in the calm window (most steps: nothing
 * else is read then), 0 otherwise (mean_over decides) */
static int in_calm_window(PyObject *model, double t0, double t1)
{
    double h = t1 - t0, lo, hi;
    return isfinite(h) && isfinite(t0) && h > 0.0 && calm_of(model, &lo, &hi) && lo <= t0 && t1 <= hi;
}

/* Wind.mean_over(t0, t1) with probability > 0: DONE with the mean and level (and *set_calm with the calm window
 * to store), DECLINED when Python must do it */
static int mean_over(const Model *w, double t0, double t1, double out[3], long *level, int *set_calm, double calm[2])
{
    double h = t1 - t0, m_d;
    long m;
    long long k0, k1;
    int any;
    *set_calm = 0;
    out[0] = out[1] = out[2] = 0.0;
    *level = 0;
    if (!isfinite(h) || !isfinite(t0) || h <= 0.0) return DECLINED;      /* at(t0), or Python raises */
    if (w->lo <= t0 && t1 <= w->hi) return DONE;
    m_d = ceil(h / RESOLUTION - 1e-9);
    m = m_d < 1.0 ? 1 : (m_d > MAX_SAMPLES ? MAX_SAMPLES : (long)m_d);
    if (!index_of((t0 + 0.5 * h / (double)m) / w->di + 1e-12, &k0)
        || !index_of((t0 + ((double)m - 0.5) * h / (double)m) / w->di + 1e-12, &k1) || k0 < 0 || k1 < k0)
        return DECLINED;                       /* before time 0: _mean_of_samples */
    any = any_occurs(w, k0, k1);
    if (any < 0) return DECLINED;
    if (!any) {
        *set_calm = calm_window(w, k0, k1, &calm[0], &calm[1]);
        return *set_calm ? DONE : DECLINED;
    }
    return windy_mean(w, t0, h, m, out, level) ? DONE : DECLINED;
}

static int put(PyObject *d, PyObject *key, PyObject *value)
{
    int rc;
    if (value == NULL) return 0;
    rc = PyDict_SetItem(d, key, value);
    Py_DECREF(value);
    return rc == 0;
}

/* _publish's assignments; the speed through a volatile exponent, so that no compiler turns pow(x, 0.5) into
 * sqrt(x) */
static int publish(PyObject *sd, const double w[3], long level)
{
    static volatile double half = 0.5;
    const double speed = pow(w[0] * w[0] + w[1] * w[1], half);
    return put(sd, k_wind_x, PyFloat_FromDouble(w[0])) && put(sd, k_wind_y, PyFloat_FromDouble(w[1]))
        && put(sd, k_wind_z, PyFloat_FromDouble(w[2])) && put(sd, k_wind_speed, PyFloat_FromDouble(speed))
        && put(sd, k_wind_level, PyLong_FromLong(level));
}

/* the step: DONE, DECLINED (nothing changed) or FAILED (a Python error while writing) */
static int model_step(PyObject *model, PyObject *sd, double ct, double h)
{
    PyObject *p = NULL;
    double t0, t1, prob, wind[3] = {0.0, 0.0, 0.0}, calm[2];
    long level = 0;
    PyObject *mean_o = PyDict_GetItemWithError(sd, k_step_mean);
    int mean = mean_o == NULL ? -1 : PyObject_IsTrue(mean_o), rc = DECLINED, set_calm = 0;
    Model w = {NULL, NULL};
    if (model == Py_None || mean <= 0 || !(h > 0.0)) return DECLINED;      /* _build, at(t) */
    t0 = ct + h;                               /* _publish(current_time + step_size, step_size) */
    t1 = t0 + h;                               /* mean_over(t, t + h) */
    if ((p = PyObject_GetAttr(model, k_p)) == NULL || !get_double(p, k_probability, &prob))
        goto done;
    if (!(prob > 0.0) || in_calm_window(model, t0, t1)) {
        rc = DONE;                             /* no episode can occur, or a calm step: zeros */
    } else {
        if (!read_model(model, p, &w)) goto done;
        rc = mean_over(&w, t0, t1, wind, &level, &set_calm, calm);
    }
    if (rc == DONE && !isfinite(wind[0] * wind[0] + wind[1] * wind[1])) rc = DECLINED;
    if (rc == DONE) {
        if (set_calm) {
            PyObject *window = Py_BuildValue("(dd)", calm[0], calm[1]);
            if (window == NULL || PyObject_SetAttr(model, k_calm, window) != 0) rc = FAILED;
            Py_XDECREF(window);
        }
        if (rc == DONE && !publish(sd, wind, level)) rc = FAILED;
    }
done:
    release_model(&w);
    Py_XDECREF(p);
    return rc;
}

static PyObject *step(PyObject *module, PyObject *args)
{
    PyObject *model, *sd, *ct_o, *h_o;
    int rc;
    (void)module;
    if (!PyArg_UnpackTuple(args, "step", 4, 4, &model, &sd, &ct_o, &h_o) || !PyDict_Check(sd)) {
        PyErr_Clear();
        PyErr_SetString(PyExc_TypeError, "step(model, variables, current_time, step_size)");
        return NULL;
    }
    rc = PyFloat_CheckExact(ct_o) && PyFloat_CheckExact(h_o)
        ? model_step(model, sd, PyFloat_AsDouble(ct_o), PyFloat_AsDouble(h_o)) : DECLINED;
    if (rc == FAILED) return NULL;
    PyErr_Clear();                             /* a lookup that raised: declined, Python does the step */
    if (rc == DONE) Py_RETURN_TRUE;
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"step", step, METH_VARARGS,
     "step(model, variables, current_time, step_size) -> bool: UavWind.do_step on its Wind model and its "
     "variables; False: nothing done, run the Python step"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_wind_ext", NULL, -1, methods,
                                       NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__wind_ext(void)
{
    size_t i;
    for (i = 0; i < sizeof names / sizeof names[0]; i++)
        if ((*names[i].key = PyUnicode_InternFromString(names[i].name)) == NULL) return NULL;
    return PyModule_Create(&moduledef);
}

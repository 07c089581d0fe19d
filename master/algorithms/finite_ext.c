/* The finiteness test of the master's Real outputs after every step, as a CPython extension function: the
 * numpy test it replaces (out.dot(zeros) != 0, see master/algorithms/finite.py) cost ~0.6-0.9 us a step, a few
 * per cent of a campaign run's step loop; this costs a call (~0.05 us) and a pass over the values. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

/* all_finite(address of n doubles, n) -> True when none is NaN or infinite */
static PyObject *all_finite(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "all_finite(address, n)");
        return NULL;
    }
    const double *v = (const double *)PyLong_AsVoidPtr(args[0]);
    Py_ssize_t n = PyLong_AsSsize_t(args[1]);
    if (PyErr_Occurred())
        return NULL;
    /* x - x is 0 for a finite x and NaN for NaN and +-inf: one test per value, no branch in the loop */
    double acc = 0.0;
    for (Py_ssize_t k = 0; k < n; k++)
        acc += v[k] - v[k];
    if (acc == 0.0)
        Py_RETURN_TRUE;
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"all_finite", (PyCFunction)(void (*)(void))all_finite, METH_FASTCALL,
     "all_finite(address of n doubles, n) -> whether none is NaN or infinite"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_finite_ext", NULL, -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__finite_ext(void)
{
    return PyModule_Create(&module);
}

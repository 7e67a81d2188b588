/* Element loops over the C library's math functions, for the batch of variants (fmus.physics.mathns.VECTOR):
   Python's math module calls these same functions for one float, so an array of variants gets the same bits.
   math.hypot is CPython's own algorithm, not the C library's: pyhypot calls that function object itself per
   element.  A CPython extension module (pd_libm), built by fmus/batch_libm.py with the machine's C compiler and
   the interpreter's headers: each function takes its arguments and the output as buffers of doubles (a float, or
   a buffer of one double, stands for every element), so a call costs a C call, not ctypes' conversions.  Plain
   calls, no vectorised variants (no -ffast-math). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

typedef double (*unary_fn)(double);
typedef double (*binary_fn)(double, double);

/* One argument: a float (every element) or a buffer of n doubles or of one (every element). */
typedef struct { Py_buffer view; int held; double value; const double *data; Py_ssize_t step; } arg_t;

static int arg_get(PyObject *obj, Py_ssize_t n, arg_t *a)
{
    a->held = 0;
    if (PyFloat_Check(obj) || PyLong_Check(obj)) {
        a->value = PyFloat_AsDouble(obj);
        if (a->value == -1.0 && PyErr_Occurred()) return -1;
        a->data = &a->value;
        a->step = 0;
        return 0;
    }
    if (PyObject_GetBuffer(obj, &a->view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return -1;
    a->held = 1;
    if (a->view.itemsize != sizeof(double) || a->view.format == NULL || strcmp(a->view.format, "d") != 0) {
        PyErr_SetString(PyExc_TypeError, "pd_libm: arguments must be C-contiguous float64 buffers or floats");
        return -1;
    }
    Py_ssize_t len = a->view.len / (Py_ssize_t)sizeof(double);
    if (len != n && len != 1) {
        PyErr_Format(PyExc_ValueError, "pd_libm: an argument of %zd elements for an output of %zd", len, n);
        return -1;
    }
    a->data = (const double *)a->view.buf;
    a->step = len == 1 ? 0 : 1;
    return 0;
}

static void arg_release(arg_t *a)
{
    if (a->held) PyBuffer_Release(&a->view);
    a->held = 0;
}

static int out_get(PyObject *obj, Py_buffer *view, Py_ssize_t *n)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE | PyBUF_FORMAT) < 0) return -1;
    if (view->itemsize != sizeof(double) || view->format == NULL || strcmp(view->format, "d") != 0) {
        PyBuffer_Release(view);
        PyErr_SetString(PyExc_TypeError, "pd_libm: the output must be a writable C-contiguous float64 buffer");
        return -1;
    }
    *n = view->len / (Py_ssize_t)sizeof(double);
    return 0;
}

/* f(x, out) */
static PyObject *unary(PyObject *const *args, Py_ssize_t nargs, unary_fn f)
{
    if (nargs != 2) { PyErr_SetString(PyExc_TypeError, "pd_libm: expected (x, out)"); return NULL; }
    Py_buffer out; Py_ssize_t n; arg_t x;
    if (out_get(args[1], &out, &n) < 0) return NULL;
    if (arg_get(args[0], n, &x) < 0) { arg_release(&x); PyBuffer_Release(&out); return NULL; }
    double *y = (double *)out.buf;
    for (Py_ssize_t i = 0; i < n; i++) y[i] = f(x.data[i * x.step]);
    arg_release(&x);
    PyBuffer_Release(&out);
    Py_RETURN_NONE;
}

/* f(a, b, out) */
static PyObject *binary(PyObject *const *args, Py_ssize_t nargs, binary_fn f)
{
    if (nargs != 3) { PyErr_SetString(PyExc_TypeError, "pd_libm: expected (a, b, out)"); return NULL; }
    Py_buffer out; Py_ssize_t n; arg_t a, b;
    b.held = 0;
    if (out_get(args[2], &out, &n) < 0) return NULL;
    if (arg_get(args[0], n, &a) < 0 || arg_get(args[1], n, &b) < 0) {
        arg_release(&a); arg_release(&b); PyBuffer_Release(&out); return NULL;
    }
    double *y = (double *)out.buf;
    for (Py_ssize_t i = 0; i < n; i++) y[i] = f(a.data[i * a.step], b.data[i * b.step]);
    arg_release(&a);
    arg_release(&b);
    PyBuffer_Release(&out);
    Py_RETURN_NONE;
}

/* pyhypot(function, a, b, out): the function object (math.hypot, a METH_FASTCALL builtin) called per element,
   its C entry called directly on two float objects of this loop's own (written in place while no one else holds
   them, else made anew) */
static PyObject *pyhypot(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) { PyErr_SetString(PyExc_TypeError, "pd_libm: expected (function, a, b, out)"); return NULL; }
    PyObject *fn = args[0];
    if (!PyCFunction_Check(fn) || PyCFunction_GET_FLAGS(fn) != METH_FASTCALL) {
        PyErr_SetString(PyExc_TypeError, "pd_libm: pyhypot needs a builtin function taking its arguments fast");
        return NULL;
    }
    _PyCFunctionFast call = (_PyCFunctionFast)(void (*)(void))PyCFunction_GET_FUNCTION(fn);
    PyObject *owner = PyCFunction_GET_SELF(fn);
    Py_buffer out; Py_ssize_t n; arg_t a, b;
    b.held = 0;
    if (out_get(args[3], &out, &n) < 0) return NULL;
    if (arg_get(args[1], n, &a) < 0 || arg_get(args[2], n, &b) < 0) {
        arg_release(&a); arg_release(&b); PyBuffer_Release(&out); return NULL;
    }
    double *y = (double *)out.buf;
    PyObject *pair[2] = {PyFloat_FromDouble(0.0), PyFloat_FromDouble(0.0)};
    PyObject *result = (pair[0] && pair[1]) ? Py_None : NULL;
    for (Py_ssize_t i = 0; result != NULL && i < n; i++) {
        for (int k = 0; k < 2; k++) {
            double v = k == 0 ? a.data[i * a.step] : b.data[i * b.step];
            if (Py_REFCNT(pair[k]) == 1) {
                ((PyFloatObject *)pair[k])->ob_fval = v;
            } else {
                Py_DECREF(pair[k]);
                pair[k] = PyFloat_FromDouble(v);
                if (pair[k] == NULL) { result = NULL; break; }
            }
        }
        if (result == NULL) break;
        PyObject *r = call(owner, pair, 2);
        if (r == NULL) { result = NULL; break; }
        y[i] = PyFloat_AsDouble(r);
        Py_DECREF(r);
    }
    Py_XDECREF(pair[0]);
    Py_XDECREF(pair[1]);
    arg_release(&a);
    arg_release(&b);
    PyBuffer_Release(&out);
    if (result == NULL) return NULL;
    Py_RETURN_NONE;
}

#define UNARY(name) \
    static PyObject *pd_##name(PyObject *self, PyObject *const *args, Py_ssize_t nargs) \
    { return unary(args, nargs, name); }
#define BINARY(name) \
    static PyObject *pd_##name(PyObject *self, PyObject *const *args, Py_ssize_t nargs) \
    { return binary(args, nargs, name); }

UNARY(exp) UNARY(tanh) UNARY(acos) UNARY(sin) UNARY(cos)
BINARY(atan2) BINARY(pow) BINARY(hypot)

static PyMethodDef methods[] = {
    {"exp", (PyCFunction)(void (*)(void))pd_exp, METH_FASTCALL, "exp(x, out)"},
    {"tanh", (PyCFunction)(void (*)(void))pd_tanh, METH_FASTCALL, "tanh(x, out)"},
    {"acos", (PyCFunction)(void (*)(void))pd_acos, METH_FASTCALL, "acos(x, out)"},
    {"sin", (PyCFunction)(void (*)(void))pd_sin, METH_FASTCALL, "sin(x, out)"},
    {"cos", (PyCFunction)(void (*)(void))pd_cos, METH_FASTCALL, "cos(x, out)"},
    {"atan2", (PyCFunction)(void (*)(void))pd_atan2, METH_FASTCALL, "atan2(a, b, out)"},
    {"pow", (PyCFunction)(void (*)(void))pd_pow, METH_FASTCALL, "pow(a, b, out)"},
    {"hypot", (PyCFunction)(void (*)(void))pd_hypot, METH_FASTCALL, "the C library's hypot(a, b, out)"},
    {"pyhypot", (PyCFunction)(void (*)(void))pyhypot, METH_FASTCALL, "pyhypot(function, a, b, out)"},
    {NULL, NULL, 0, NULL}
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "pd_libm", NULL, -1, methods};

PyMODINIT_FUNC PyInit_pd_libm(void) { return PyModule_Create(&module); }

/* Element loops over the C library's math functions, for the batch of variants (fmus.physics.mathns.VECTOR):
   Python's math module calls these same functions for one float, so an array of variants gets the same bits.
   math.hypot is CPython's own algorithm, not the C library's: pd_pyhypot calls that function object itself per
   element.  Built by fmus/batch_libm.py with the machine's C compiler and the interpreter's headers, loaded into
   the interpreter (the GIL held); plain calls, no vectorised variants (no -ffast-math). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

void pd_exp(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = exp(x[i]); }
void pd_tanh(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = tanh(x[i]); }
void pd_acos(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = acos(x[i]); }
void pd_sin(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = sin(x[i]); }
void pd_cos(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = cos(x[i]); }
void pd_atan2(const double *a, const double *b, double *y, long n) { for (long i = 0; i < n; i++) y[i] = atan2(a[i], b[i]); }
void pd_pow(const double *a, const double *b, double *y, long n) { for (long i = 0; i < n; i++) y[i] = pow(a[i], b[i]); }
void pd_hypot(const double *a, const double *b, double *y, long n) { for (long i = 0; i < n; i++) y[i] = hypot(a[i], b[i]); }

int pd_pyhypot(PyObject *f, const double *a, const double *b, double *y, long n)
{
    for (long i = 0; i < n; i++) {
        PyObject *args[2] = {PyFloat_FromDouble(a[i]), PyFloat_FromDouble(b[i])};
        if (args[0] == NULL || args[1] == NULL) { Py_XDECREF(args[0]); Py_XDECREF(args[1]); return -1; }
        PyObject *r = PyObject_Vectorcall(f, args, 2, NULL);
        Py_DECREF(args[0]);
        Py_DECREF(args[1]);
        if (r == NULL) return -1;
        y[i] = PyFloat_AsDouble(r);
        Py_DECREF(r);
    }
    return 0;
}

/* Element loops over the C library's math functions, for the batch of variants (fmus.physics.mathns.VECTOR):
   Python's math module calls these same functions for one float, so an array of variants gets the same bits.
   Built by fmus/batch_libm.py with the machine's C compiler; plain calls, no vectorised variants (no -ffast-math). */
#include <math.h>

void pd_exp(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = exp(x[i]); }
void pd_tanh(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = tanh(x[i]); }
void pd_acos(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = acos(x[i]); }
void pd_sin(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = sin(x[i]); }
void pd_cos(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = cos(x[i]); }
void pd_atan2(const double *a, const double *b, double *y, long n) { for (long i = 0; i < n; i++) y[i] = atan2(a[i], b[i]); }
void pd_pow(const double *a, const double *b, double *y, long n) { for (long i = 0; i < n; i++) y[i] = pow(a[i], b[i]); }
void pd_hypot(const double *a, const double *b, double *y, long n) { for (long i = 0; i < n; i++) y[i] = hypot(a[i], b[i]); }

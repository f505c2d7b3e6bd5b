/* Magnetizing curves psi_m(I) of satmotor/machine/magnetics.py and satmotor/machine/table_curve.py, in C99.
 * Every function works on a caller-owned sm_curve; the struct holds no pointers (a byte copy is a
 * valid copy).  The same formulas in the same order as the Python, so the same floats. */
#ifndef SM_CURVES_H
#define SM_CURVES_H

#include <stddef.h>

#include "sm_common.h"

/* Most points a table curve holds (the origin included; the mirrored points are not stored). */
#define SM_TABLE_MAX 512

typedef enum {
    SM_CURVE_LINEAR,
    SM_CURVE_ARCTAN,
    SM_CURVE_EXPONENTIAL,
    SM_CURVE_POLYNOMIAL,
    SM_CURVE_TABLE
} sm_curve_kind;

typedef struct {
    sm_curve_kind kind;
    double L_m0, L_m_inf, I_par, poly_b;
    int poly_n;
    /* table: n points x[k] (x[0] = 0), segment k: psi = y0 + t (d0 + t (c2 + t c3)), t = I - x[k];
     * the last segment is the straight line beyond the last point (c2 = c3 = 0) */
    int n;
    double x[SM_TABLE_MAX], y0[SM_TABLE_MAX], d0[SM_TABLE_MAX], c2[SM_TABLE_MAX], c3[SM_TABLE_MAX];
    double m0; /* m(0) [H] */
} sm_curve;

/* Mirrors params.make_curve: name is one of arctan, exponential, polynomial, table, linear; the
 * parameters a family does not use are ignored.  table_path: CSV file read as
 * TableCurve.from_csv (sm_table_file.h).  Returns SM_CORE_OK or SM_ERR_PARAM with the ParameterError text in msg. */
int sm_curve_init(sm_curve *c, const char *name, double L_m0, double L_m_inf, double I_par,
                  double poly_b, int poly_n, const char *table_path, char *msg, size_t msg_len);

/* Table curve from points (TableCurve(i_mu, psi_m) without a file: messages number the points). */
int sm_curve_init_table(sm_curve *c, const double *i_mu, const double *psi_m, int n_points,
                        char *msg, size_t msg_len);

/* psi(I) [Wb], m(I) [H], dm/dI [H/A], L_dyn [H] for I >= 0.  Never crash on NaN/inf (the result
 * is then NaN or inf, as in Python); the polynomial curve returns NaN if its Newton iteration did
 * not converge (Python raises ArithmeticError). */
double sm_curve_psi(const sm_curve *c, double I);
void sm_curve_evaluate(const sm_curve *c, double I, double *psi, double *m, double *dm, double *L_dyn);
double sm_curve_m(const sm_curve *c, double I);
double sm_curve_dm_dI(const sm_curve *c, double I);
double sm_curve_L_dyn(const sm_curve *c, double I);

/* Inverse: the I >= 0 with psi(I) = psi.  SM_CORE_OK, SM_ERR_NOCONV or SM_ERR_NONFINITE (*I = NaN). */
int sm_curve_current(const sm_curve *c, double psi, double *I);

/* Root I >= 0 of a I + psi(I) = cc (a >= 0), and psi(I).  SM_CORE_OK; SM_ERR_NONFINITE for a non-finite
 * a or cc; SM_ERR_NOCONV when the iteration does not converge (Python: ArithmeticError). */
int sm_curve_solve(const sm_curve *c, double a, double cc, double *I, double *psi);

/* _Curve.solve(a, cc, guess): sm_curve_solve started from guess [A] instead of its lower bound
 * cc / (a + m0) when guess is finite and above that bound (a warm start; the linear and polynomial
 * curves ignore it, as in Python).  The root agrees with the cold one to the solver's tolerance. */
int sm_curve_solve_from(const sm_curve *c, double a, double cc, double guess, double *I, double *psi);

/* sizeof(sm_curve), for hosts that allocate it without the header (ctypes). */
size_t sm_curve_size(void);

/* (M_d, M_q, M_dq) of magnetics.inductance_matrix. */
void sm_inductance_matrix(double m, double dm, double i_d, double i_q, double I, double *Md,
                          double *Mq, double *Mdq);

#endif

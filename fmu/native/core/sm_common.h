/* Shared small things of the native satmotor core: status codes, message buffers, Python-style
 * formatting of values in messages (the wording of satmotor/errors.py). C99, no global state.
 * The functions declared here are defined in sm_common.c.
 *
 * Same floats as the Python package: the core evaluates the Python's formulas in the Python's
 * order in IEEE double, and calls the libm CPython's math module calls (atan2, exp, expm1, pow);
 * math.hypot is CPython's own algorithm (sm_hypot), the arctan curve's atan the package's own
 * (sm_atan, satmotor/machine/atan.py).  That holds when the compiler neither fuses
 * a*b+c into an fma nor keeps excess precision: build with -std=c99 (GCC: -ffp-contract=off then)
 * or pass -ffp-contract=off explicitly (needed on aarch64 with gnu modes), SSE2 math on 32-bit
 * x86 (-msse2 -mfpmath=sse), never -ffast-math.  The results then equal the Python's on the same
 * platform libm. */
#ifndef SM_COMMON_H
#define SM_COMMON_H

#include <stddef.h>

enum {
    SM_CORE_OK = 0,
    SM_ERR_PARAM = 1,     /* a bad parameter: msg names it and its value (a ParameterError) */
    SM_ERR_NOCONV = 2,    /* an iteration did not converge (Python: ArithmeticError) */
    SM_ERR_NONFINITE = 3, /* a non-finite input or state (Python: ArithmeticError / ParameterError) */
    SM_ERR_ARG = 4        /* a NULL pointer or similar misuse of the C API */
};

/* Caller-owned message buffer type (any char array works; 256 is the recommended size). */
#define SM_MSG_LEN 256
typedef char sm_msg[SM_MSG_LEN];

/* Python repr(float) of v into buf (shortest round-trip digits, 'nan', 'inf', '1e-05', '2.0').
 * Returns buf. buf_len >= 32 always suffices. */
char *sm_repr_double(double v, char *buf, size_t buf_len);

/* Python repr(str) of the NUL-terminated s into buf (quotes and escapes as Python does for ASCII;
 * other bytes are copied). Truncated to buf_len. Returns buf. */
char *sm_repr_str(const char *s, char *buf, size_t buf_len);

/* "{field} = {repr(value)}: must be a finite number{bound}" as errors.require_number: lower bound
 * (has_lower), inclusive or not; returns SM_CORE_OK or SM_ERR_PARAM (message written). */
int sm_require_number(const char *field, double value, int has_lower, double lower, int inclusive,
                      char *msg, size_t msg_len);

/* "{field} = {value}: must be an integer >= {lower}" as errors.require_integer. */
int sm_require_integer(const char *field, int value, int lower, char *msg, size_t msg_len);

/* Writes "{source}: " (when source is non-NULL) "{field} = {value_repr}: {reason}" into msg and
 * returns SM_ERR_PARAM (the str() of a ParameterError). */
int sm_param_error(char *msg, size_t msg_len, const char *source, const char *field,
                   const char *value_repr, const char *reason);

/* Longest text sm_parse_float reads whole [bytes]. */
#define SM_FLOAT_TEXT_MAX 4096

/* Python float(s) of the stripped NUL-terminated s: a decimal or 'nan'/'inf'/'infinity' with a sign,
 * underscores between digits (PEP 515); strtod in the C locale without its extensions (hex floats,
 * nan(...)), whatever LC_NUMERIC the host set.  1 and *v the value, or 0 (not a number). */
int sm_parse_float(const char *s, double *v);

/* math.hypot(x, y) of CPython (>= 3.11: its own vector_norm, faithfully and nearly always
 * correctly rounded; the libm hypot differs in the last bit on about 0.2 % of inputs). */
double sm_hypot(double x, double y);

#endif

/* The compiled stepping engine: the fmpy master's loop (orchestration/run/master.py, _steps) in C.
 *
 * Python (orchestration/run/c_engine/stepper.py) instantiates the two FMUs, sets their parameters and
 * initializes them exactly as the fmpy master does (the same FMUInstance code), then fills one
 * se_config (the instances, their FMI functions, the value references, the wiring, the profile table,
 * the measurement model) and one se_state (its buffers) and calls se_advance until it returns SE_DONE
 * or SE_FAILED.  se_advance returns early, with the state ready to go on, when the row buffer is full
 * (SE_ROWS_FULL: Python hands the rows to the recorder, whose observer computes the metrics) or when
 * the noise draws are used up (SE_NOISE_EMPTY: Python draws the next block with numpy, as the fmpy
 * master does).  The engine allocates nothing and keeps no global state.
 *
 * The same calls in the same order with the same values as the fmpy master, step k (t = t0 + k h):
 *   - the profiles at t (orchestration/scenario/profiles.py, value(t), same operation order);
 *   - at a controller sample (k % ctrl_every == 0): the controller's inputs (the measured plant
 *     outputs when the scenario has measurements), fmiSetReal, Jacobi: hold the controller outputs,
 *     doStep(t, Ts), get its Real, Integer and Boolean outputs;
 *   - when k % every == 0: one row [t, plant Reals, controller Reals, Integers, Booleans, profiles,
 *     measured signals], as float64;
 *   - k < n: the plant's inputs (Gauss-Seidel: the new controller outputs; Jacobi: the held ones),
 *     fmiSetReal, doStep(t, h), get its Real outputs.
 * Compiled with -ffp-contract=off: no fused multiply-add, the arithmetic of the Python profiles. */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"

#if defined(_WIN32)
#define SE_EXPORT __declspec(dllexport)
#else
#define SE_EXPORT __attribute__((visibility("default")))
#endif

#define SE_ABI 1 /* se_abi(): Python checks it against its structure layout */

enum { SE_DONE = 0, SE_ROWS_FULL = 1, SE_NOISE_EMPTY = 2, SE_FAILED = -1 };
enum { SRC_PLANT = 0, SRC_CONTROLLER = 1, SRC_PROFILE = 2 };
enum { P_CONSTANT = 1, P_STEP, P_RAMP, P_TABLE, P_SINE };
enum { F_GET_REAL = 0, F_SET_REAL, F_GET_INT, F_GET_BOOL, F_DO_STEP, F_COUNT };
#define TERM_NUMBERS 5

typedef void (*se_function)(void);

typedef struct {
    void *instance;               /* fmi2Component or fmi3Instance, instantiated and initialized */
    int32_t fmi3;                 /* 0: FMI 2.0, 1: FMI 3.0 */
    const char *name;             /* "plant" or "controller", for the messages */
    se_function fn[F_COUNT];      /* fmi2GetReal/fmi3GetFloat64, ...SetReal, ...GetInteger/Int32,
                                     ...GetBoolean, ...DoStep, of this instance's library */
    const char *fn_name[F_COUNT]; /* their names */
} se_unit;

typedef struct { /* a unit's input port: the value references and where each value comes from */
    int32_t n;
    const uint32_t *vr;
    const int32_t *src_kind;  /* SRC_* */
    const int32_t *src_index; /* index in the plant's / controller's Real outputs, or the profile */
} se_inputs;

typedef struct {
    se_unit plant, ctrl;
    int64_t n_steps, every, ctrl_every; /* the last step n, rows every `every` steps, the controller
                                           every `ctrl_every` steps */
    double t0, h, Ts;                   /* [s] */
    int32_t jacobi;
    int32_t n_po, n_co, n_ci, n_cb;     /* plant Reals, controller Reals, Integers, Booleans out */
    const uint32_t *vr_po, *vr_co, *vr_ci, *vr_cb;
    se_inputs p_in, c_in;
    /* profiles: profile j adds terms prof_first[j] .. + prof_n[j] - 1 (prof_sum[j]: as a Sum, from
       0.0; else the one term's value); term i: kind, numbers a[5 i ..], table points first, n */
    int32_t n_prof;
    const int32_t *prof_first, *prof_n, *prof_sum;
    const int32_t *term_kind, *term_first, *term_points;
    const double *term_a, *pt_t, *pt_v;
    /* measurements: signal m measures plant output meas_index[m], adds draw column meas_col[m]
       (-1: none), quantizes with step meas_q[m] (0: none) */
    int32_t n_meas, n_noisy;
    const int32_t *meas_index, *meas_col;
    const double *meas_q;
    int32_t n_cols; /* of a row: 1 + n_po + n_co + n_ci + n_cb + n_prof + n_meas */
} se_config;

typedef struct {
    int64_t k;       /* the next step */
    int32_t started; /* the initial outputs read */
    /* buffers, sized by the caller */
    double *pvals, *cvals, *held;          /* n_po, n_co, n_co (Jacobi: the held controller outputs) */
    int32_t *ivals;                        /* n_ci */
    void *bvals;                           /* n_cb: int32_t (FMI 2.0) or bool (FMI 3.0) */
    double *p_invals, *c_invals, *fv;      /* n_p_in, n_c_in, n_prof */
    double *mvals, *mrow;                  /* n_po (the plant outputs as measured), n_meas */
    const double *noise;                   /* draws, row-major, n_noisy per row (scaled by the std) */
    int64_t noise_rows, noise_next;
    /* a failure */
    int32_t failed_unit, failed_status;    /* 0 plant, 1 controller; the FMI status */
    int32_t failed_function;               /* F_* */
    double failed_time;                    /* [s] */
    char message[256];
} se_state;

SE_EXPORT int32_t se_abi(void) { return SE_ABI; }

/* ---- profiles: orchestration/scenario/profiles.py, value(t) ---- */

static double table_value(const double *ts, const double *vs, int32_t n, double t)
{
    int32_t lo = 0, hi = n, i;
    double t0, v0;
    if (t <= ts[0]) return vs[0];
    if (t >= ts[n - 1]) return vs[n - 1];
    while (lo < hi) { /* bisect_right: the first index with ts[i] > t */
        int32_t mid = lo + (hi - lo) / 2;
        if (t < ts[mid]) hi = mid;
        else lo = mid + 1;
    }
    i = lo;
    t0 = ts[i - 1];
    v0 = vs[i - 1];
    return v0 + (vs[i] - v0) * (t - t0) / (ts[i] - t0);
}

static double term_value(const se_config *c, int32_t i, double t)
{
    const double *a = c->term_a + TERM_NUMBERS * i;
    double v;
    switch (c->term_kind[i]) {
    case P_CONSTANT: return a[0]; /* level */
    case P_STEP: return t >= a[0] ? a[1] : a[2]; /* time, level, initial */
    case P_RAMP: /* start, from, slope, lo, hi */
        if (t < a[0]) return a[1];
        v = a[1] + (t - a[0]) * a[2];
        return v > a[4] ? a[4] : (v < a[3] ? a[3] : v);
    case P_TABLE:
        return table_value(c->pt_t + c->term_first[i], c->pt_v + c->term_first[i], c->term_points[i], t);
    default: /* P_SINE: start, offset, amplitude, w, phase */
        if (t < a[0]) return 0.0;
        return a[1] + a[2] * sin(a[3] * (t - a[0]) + a[4]);
    }
}

static void profiles(const se_config *c, double t, double *fv)
{
    int32_t j, i;
    for (j = 0; j < c->n_prof; ++j) {
        if (c->prof_sum[j]) {
            double s = 0.0;
            for (i = 0; i < c->prof_n[j]; ++i) s += term_value(c, c->prof_first[j] + i, t);
            fv[j] = s;
        } else {
            fv[j] = term_value(c, c->prof_first[j], t);
        }
    }
}

/* ---- FMI calls, each status checked ---- */

static int failed(se_state *s, const se_unit *u, int32_t unit, int32_t function, int status, double t)
{
    s->failed_unit = unit;
    s->failed_status = status;
    s->failed_function = function;
    s->failed_time = t;
    snprintf(s->message, sizeof s->message, "%s: %s returned status %d at t = %.17g s", u->name,
             u->fn_name[function], status, t);
    return SE_FAILED;
}

static int get_real(const se_unit *u, const uint32_t *vr, int32_t n, double *v)
{
    if (u->fmi3) return (int)((fmi3GetFloat64TYPE *)u->fn[F_GET_REAL])(u->instance, vr, (size_t)n, v, (size_t)n);
    return (int)((fmi2GetRealTYPE *)u->fn[F_GET_REAL])(u->instance, vr, (size_t)n, v);
}

static int set_real(const se_unit *u, const uint32_t *vr, int32_t n, const double *v)
{
    if (u->fmi3) return (int)((fmi3SetFloat64TYPE *)u->fn[F_SET_REAL])(u->instance, vr, (size_t)n, v, (size_t)n);
    return (int)((fmi2SetRealTYPE *)u->fn[F_SET_REAL])(u->instance, vr, (size_t)n, v);
}

static int get_int(const se_unit *u, const uint32_t *vr, int32_t n, int32_t *v)
{
    if (u->fmi3) return (int)((fmi3GetInt32TYPE *)u->fn[F_GET_INT])(u->instance, vr, (size_t)n, v, (size_t)n);
    return (int)((fmi2GetIntegerTYPE *)u->fn[F_GET_INT])(u->instance, vr, (size_t)n, (fmi2Integer *)v);
}

static int get_bool(const se_unit *u, const uint32_t *vr, int32_t n, void *v)
{
    if (u->fmi3)
        return (int)((fmi3GetBooleanTYPE *)u->fn[F_GET_BOOL])(u->instance, vr, (size_t)n, (fmi3Boolean *)v,
                                                             (size_t)n);
    return (int)((fmi2GetBooleanTYPE *)u->fn[F_GET_BOOL])(u->instance, vr, (size_t)n, (fmi2Boolean *)v);
}

static int do_step(const se_unit *u, double t, double h)
{
    if (u->fmi3) {
        fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
        fmi3Float64 last = 0.0;
        return (int)((fmi3DoStepTYPE *)u->fn[F_DO_STEP])(u->instance, t, h, fmi3True, &event, &terminate, &early,
                                                        &last);
    }
    return (int)((fmi2DoStepTYPE *)u->fn[F_DO_STEP])(u->instance, t, h, fmi2True);
}

#define CHECK(call, unit_ptr, unit, function, t)                                                          \
    do {                                                                                                 \
        int r_ = (call);                                                                                 \
        if (r_ > 1) return failed(s, (unit_ptr), (unit), (function), r_, (t));                           \
    } while (0)

/* the controller's outputs: Reals, Integers, Booleans */
static int read_controller(const se_config *c, se_state *s, double t)
{
    const se_unit *u = &c->ctrl;
    CHECK(get_real(u, c->vr_co, c->n_co, s->cvals), u, 1, F_GET_REAL, t);
    if (c->n_ci > 0) CHECK(get_int(u, c->vr_ci, c->n_ci, s->ivals), u, 1, F_GET_INT, t);
    if (c->n_cb > 0) CHECK(get_bool(u, c->vr_cb, c->n_cb, s->bvals), u, 1, F_GET_BOOL, t);
    return SE_DONE;
}

/* a unit's input values from the plant outputs pv, the controller outputs cv and the profiles */
static void gather(const se_inputs *in, const double *pv, const double *cv, const double *fv, double *out)
{
    int32_t i;
    for (i = 0; i < in->n; ++i) {
        int32_t j = in->src_index[i];
        out[i] = in->src_kind[i] == SRC_PLANT ? pv[j] : (in->src_kind[i] == SRC_CONTROLLER ? cv[j] : fv[j]);
    }
}

/* the measured plant outputs (orchestration/run/measurement_noise.py, MeasurementNoise.__call__) */
static void measure(const se_config *c, se_state *s)
{
    const double *z = s->noise + s->noise_next * c->n_noisy;
    int32_t m;
    memcpy(s->mvals, s->pvals, sizeof(double) * (size_t)c->n_po);
    for (m = 0; m < c->n_meas; ++m) {
        int32_t i = c->meas_index[m], j = c->meas_col[m];
        double x = j >= 0 ? s->mvals[i] + z[j] : s->mvals[i], q = c->meas_q[m];
        if (q != 0.0) x = q * floor(x / q + 0.5);
        s->mvals[i] = x;
        s->mrow[m] = x;
    }
    if (c->n_noisy > 0) ++s->noise_next;
}

static void record(const se_config *c, const se_state *s, double t, double *row)
{
    int32_t i;
    *row++ = t;
    for (i = 0; i < c->n_po; ++i) *row++ = s->pvals[i];
    for (i = 0; i < c->n_co; ++i) *row++ = s->cvals[i];
    for (i = 0; i < c->n_ci; ++i) *row++ = (double)s->ivals[i];
    for (i = 0; i < c->n_cb; ++i)
        *row++ = c->ctrl.fmi3 ? (((const bool *)s->bvals)[i] ? 1.0 : 0.0) : (double)((const int32_t *)s->bvals)[i];
    for (i = 0; i < c->n_prof; ++i) *row++ = s->fv[i];
    for (i = 0; i < c->n_meas; ++i) *row++ = s->mrow[i];
}

/* Steps from s->k on, recording into rows (max_rows rows of n_cols); *n_rows: the rows written.  SE_DONE
   after the last step, SE_ROWS_FULL / SE_NOISE_EMPTY: call again (with the rows handed over / new
   draws), SE_FAILED: s->failed_* and s->message say which call failed. */
SE_EXPORT int32_t se_advance(const se_config *c, se_state *s, double *rows, int64_t max_rows, int64_t *n_rows)
{
    const se_unit *p = &c->plant, *u = &c->ctrl;
    const double *held = c->jacobi ? s->held : s->cvals;
    int64_t k;
    *n_rows = 0;
    if (!s->started) { /* the initial outputs */
        CHECK(get_real(p, c->vr_po, c->n_po, s->pvals), p, 0, F_GET_REAL, c->t0);
        if (read_controller(c, s, c->t0) != SE_DONE) return SE_FAILED;
        if (c->jacobi) memcpy(s->held, s->cvals, sizeof(double) * (size_t)c->n_co);
        s->started = 1;
    }
    for (k = s->k; k <= c->n_steps; ++k) {
        double t = c->t0 + (double)k * c->h;
        int sample = k % c->ctrl_every == 0, kept = k % c->every == 0;
        if (kept && *n_rows == max_rows) {
            s->k = k;
            return SE_ROWS_FULL;
        }
        if (sample && c->n_noisy > 0 && s->noise_next == s->noise_rows) {
            s->k = k;
            return SE_NOISE_EMPTY;
        }
        profiles(c, t, s->fv);
        if (sample) {
            const double *pv = s->pvals;
            if (c->n_meas > 0) {
                measure(c, s);
                pv = s->mvals;
            }
            gather(&c->c_in, pv, held, s->fv, s->c_invals);
            CHECK(set_real(u, c->c_in.vr, c->c_in.n, s->c_invals), u, 1, F_SET_REAL, t);
            if (c->jacobi) memcpy(s->held, s->cvals, sizeof(double) * (size_t)c->n_co);
            CHECK(do_step(u, t, c->Ts), u, 1, F_DO_STEP, t);
            if (read_controller(c, s, t) != SE_DONE) return SE_FAILED;
        }
        if (kept) {
            record(c, s, t, rows + *n_rows * c->n_cols);
            ++*n_rows;
        }
        if (k == c->n_steps) break;
        gather(&c->p_in, s->pvals, held, s->fv, s->p_invals);
        CHECK(set_real(p, c->p_in.vr, c->p_in.n, s->p_invals), p, 0, F_SET_REAL, t);
        CHECK(do_step(p, t, c->h), p, 0, F_DO_STEP, t);
        CHECK(get_real(p, c->vr_po, c->n_po, s->pvals), p, 0, F_GET_REAL, t);
    }
    s->k = c->n_steps + 1;
    return SE_DONE;
}

"""Benchmark of the plant: right-hand-side throughput and fixed-step RK4 vs scipy solve_ivp.

Run ``python -m bench plant``; prints the numbers and replaces its own section of ``bench/RESULTS.md``
(the block between ``<!-- plant:start -->`` and ``<!-- plant:end -->``; see ``bench.common.write_section``).

(a) ``Plant.derivatives`` calls per second on a running, loaded state of the default motor.
(b) One simulated second of a DOL start (rated smooth voltage ``V cos(w t), V sin(w t)`` inside
    the right-hand side, rated load torque step at ``T_LOAD``, integrated in two segments
    ``[0, T_LOAD]`` and ``[T_LOAD, 1]``): fixed-step RK4 (``satmotor.machine.integrate.rk4``) against
    ``solve_ivp(RK45, rtol=1e-8, atol=1e-10)`` at equal accuracy, both measured against a
    ``solve_ivp(DOP853, rtol=atol=1e-12)`` reference at t = 1 s.
"""

from __future__ import annotations

import argparse
import datetime
import math
import platform
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

from bench.common import cpu_model, write_section
from satmotor.machine.integrate import rk4
from satmotor.machine.params import MotorParams, RatedData
from satmotor.machine.plant import N_STATES, OMEGA_M, PSI_R_A, PSI_R_B, PSI_S_A, PSI_S_B, THETA_M, Plant

T_END, T_LOAD = 1.0, 0.6
RK45_TOL = dict(rtol=1e-8, atol=1e-10)
REF_TOL = dict(rtol=1e-12, atol=1e-12)
# steps per simulated second, multiples of 5 so that T_LOAD is a step time
RK4_STEPS = (1000, 1250, 1500, 2000, 2500, 3000, 4000, 5000, 6000, 8000, 10000, 12500, 15000, 16000,
             17500, 20000, 25000, 30000, 40000, 50000)
REPEATS = 3
N_RHS = 50_000

PLANT = Plant(MotorParams())
RATED = RatedData()
V, W, T_N = RATED.V_phase_peak, RATED.omega_e, RATED.T_n
X0 = (0.0,) * N_STATES


def f(t, x, T_load):
    """Right-hand side with the continuous-time rated supply [SI]."""
    wt = W * t
    return PLANT.derivatives(t, x, V * math.cos(wt), V * math.sin(wt), T_load)


def run_ivp(method, tol):
    """Two-segment solve_ivp run; returns (final state, nfev)."""
    s1 = solve_ivp(f, (0.0, T_LOAD), X0, method=method, args=(0.0,), **tol)
    s2 = solve_ivp(f, (T_LOAD, T_END), s1.y[:, -1], method=method, args=(T_N,), **tol)
    assert s1.success and s2.success, (s1.message, s2.message)
    return s2.y[:, -1], s1.nfev + s2.nfev


def run_rk4(n):
    """Two-segment fixed-step RK4 with n steps per simulated second; returns (final state, nfev)."""
    n1 = round(n * T_LOAD)
    x = rk4(f, 0.0, X0, T_LOAD, n1, (0.0,))
    x = rk4(f, T_LOAD, x, T_END - T_LOAD, n - n1, (T_N,))
    return np.array(x), 4 * n


def run_plant_step(n):
    """Same step count with Plant.step (voltage held at the mid-step value, ZOH), for the per-step cost."""
    h = T_END / n
    x = X0
    step = PLANT.step
    for k in range(n):
        t = k * h
        wt = W * (t + 0.5 * h)
        x = step(t, x, V * math.cos(wt), V * math.sin(wt), T_N if t >= T_LOAD else 0.0, h)
    return x


def error(x, ref):
    """max_i |x_i - ref_i| / s_i, s_i = |psi_s|, |psi_r| (vector magnitudes), |omega_m|, |theta_m| of ref."""
    ps, pr = math.hypot(ref[PSI_S_A], ref[PSI_S_B]), math.hypot(ref[PSI_R_A], ref[PSI_R_B])
    scale = np.empty(N_STATES)
    scale[[PSI_S_A, PSI_S_B]], scale[[PSI_R_A, PSI_R_B]] = ps, pr
    scale[OMEGA_M], scale[THETA_M] = abs(ref[OMEGA_M]), abs(ref[THETA_M])
    return float(np.max(np.abs(np.asarray(x) - ref) / scale))


def best_time(fn, *args):
    best, res = math.inf, None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        res = fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best, res


def rhs_rate(x):
    der = PLANT.derivatives
    v_a, v_b = V * math.cos(0.3), V * math.sin(0.3)

    def loop():
        for _ in range(N_RHS):
            der(0.0, x, v_a, v_b, T_N)

    return N_RHS / best_time(loop)[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    print("reference: solve_ivp DOP853 rtol=atol=1e-12 ...", flush=True)
    ref, ref_nfev = run_ivp("DOP853", REF_TOL)
    print(f"  final state {np.array2string(ref, precision=6)}  nfev {ref_nfev}")
    rate = rhs_rate(tuple(ref))
    print(f"(a) Plant.derivatives: {rate:,.0f} evaluations/s ({1e6 / rate:.2f} us each)")

    t_ivp, (x_ivp, nfev_ivp) = best_time(run_ivp, "RK45", RK45_TOL)
    err_ivp = error(x_ivp, ref)
    print(f"(b) solve_ivp RK45 rtol=1e-8 atol=1e-10: {t_ivp:.3f} s, nfev {nfev_ivp}, error {err_ivp:.2e}")

    chosen, scan = None, []
    for n in RK4_STEPS:  # coarse to fine: the first n that meets the error is the largest step
        x, _ = run_rk4(n)
        e = error(x, ref)
        scan.append((n, e))
        print(f"    RK4 n={n:6d} (h={1e3 / n:.4g} ms): error {e:.2e}")
        if e <= err_ivp:
            chosen = n
            break
    if chosen is None:
        raise SystemExit("no RK4 step in RK4_STEPS reaches the RK45 error; extend the list")
    t_rk4, (x_rk4, nfev_rk4) = best_time(run_rk4, chosen)
    err_rk4 = error(x_rk4, ref)
    t_step = best_time(run_plant_step, chosen)[0]
    ratio = t_ivp / t_rk4
    print(f"(b) RK4 n={chosen} (h={1e3 / chosen:.4g} ms): {t_rk4:.3f} s, nfev {nfev_rk4}, "
          f"error {err_rk4:.2e}")
    print(f"    Plant.step loop (ZOH input) n={chosen}: {t_step:.3f} s")
    print(f"    ratio solve_ivp RK45 time / RK4 time = {ratio:.2f}")

    env = (f"{datetime.date.today().isoformat()}, Python {platform.python_version()}, "
           f"numpy {np.__version__}, scipy {__import__('scipy').__version__}, CPU: {cpu_model()}")
    print(f"environment: {env}; benchmark wall time {time.perf_counter() - t0:.1f} s")
    if not a.no_write:
        write_results(env, rate, ref_nfev, (t_ivp, nfev_ivp, err_ivp), (chosen, t_rk4, nfev_rk4, err_rk4),
                      t_step, ratio, scan)


def write_results(env, rate, ref_nfev, ivp, rk, t_step, ratio, scan):
    t_ivp, nfev_ivp, err_ivp = ivp
    n, t_rk4, nfev_rk4, err_rk4 = rk
    scan_txt = ", ".join(f"{k}: {e:.1e}" for k, e in scan)
    text = f"""## Plant benchmark

Measured {env}.

| quantity | value |
|---|---|
| (a) `Plant.derivatives` evaluations per second | {rate:,.0f} ({1e6 / rate:.2f} us each) |
| (b) `solve_ivp` RK45 rtol=1e-8 atol=1e-10: wall time | {t_ivp:.3f} s |
| (b) RK45: rhs evaluations / error at t = 1 s | {nfev_ivp} / {err_ivp:.2e} |
| (b) fixed-step RK4, {n} steps (h = {1e3 / n:.4g} ms): wall time | {t_rk4:.3f} s |
| (b) RK4: rhs evaluations / error at t = 1 s | {nfev_rk4} / {err_rk4:.2e} |
| **ratio RK45 time / RK4 time** | **{ratio:.2f}** |
| (info) `Plant.step` loop, same {n} steps, mid-step ZOH input | {t_step:.3f} s |
| (info) reference DOP853 rtol=atol=1e-12: rhs evaluations | {ref_nfev} |

RK4 error scan (steps per second: error): {scan_txt}.

What was measured: (a) calls per second of `Plant.derivatives` (pure Python) on the loaded running
state of the default 4 kW motor at t = 1 s. (b) one simulated second of a direct-on-line start of that
motor, started from rest with zero fluxes, rated voltage applied as the smooth `V cos(w t), V sin(w t)`
inside the right-hand side and the rated load torque stepped at t = {T_LOAD} s by integrating in two
segments. The error is the largest state-component error at t = 1 s against a `solve_ivp` DOP853
(rtol = atol = 1e-12) reference, each component divided by the magnitude of its group in the reference
(|psi_s|, |psi_r|, |omega_m|, |theta_m|). The RK4 step is the largest in the scan whose error does not
exceed that of RK45, so both solvers are timed at (at least) equal accuracy; times are the best of
{REPEATS} runs with `time.perf_counter`, integration only (no output recording beyond what `solve_ivp`
keeps internally). RK4 is `satmotor.machine.integrate.rk4` with the voltages computed at the stage times; the
`Plant.step` row is the per-step loop used by the simulations (voltage held at its mid-step value),
timed for the per-call overhead only. Rerun with `python -m bench plant` (or `make bench`);
it prints the same numbers and rewrites this section.
"""
    write_section("plant", text)


if __name__ == "__main__":
    sys.exit(main())

"""Per-step cost of the plant on the Gamma form (l_s = 0) against today's plant (issue 19, item 1).

Run ``python -m bench forms [--fmus build/fmus]``; prints a table and replaces its own section of
``bench/RESULTS.md`` (between ``<!-- forms:start -->`` and ``<!-- forms:end -->``).

Three motors, each stepped through a 1-s direct-on-line start (rated 400 V, 50 Hz, held over each step,
10000 steps of 1e-4 s, one RK4 sub-step each; rated load from 0.6 s): ``T arctan`` (today's default motor),
``Gamma arctan`` (the same motor with l_s = 0 and l_r = 2 l_s: the Gamma branch, the same curve) and
``qu2012_2kw2`` (the measured 2.2-kW machine: Gamma branch, polynomial curve n = 8).  Per step: the
plain-Python ``Plant.step`` and the native plant FMU's ``fmi2DoStep`` (FMI 2.0, with one ``fmi2SetReal``
of the three inputs and one ``fmi2GetReal`` of the outputs per step, as a master does).  Best of 3.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import platform
import sys
import time
from pathlib import Path

from bench.common import write_section
from satmotor.machine.library import preset
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import N_STATES, Plant

ROOT = Path(__file__).resolve().parents[1]
N, H, REPEATS = 10000, 1e-4, 7
V, W = 400.0 * math.sqrt(2.0 / 3.0), 2.0 * math.pi * 50.0


def motors():
    m = MotorParams()
    gamma = dataclasses.replace(m, l_s=0.0, l_r=2.0 * m.l_r)
    qu = preset("qu2012_2kw2")
    d = preset("default_4kw")
    return (("T arctan (today)", m, dict(d.values), 26.71),
            ("Gamma arctan (l_s = 0)", gamma, dict(d.values, l_s=0.0, l_r=2.0 * m.l_r), 26.71),
            ("qu2012_2kw2 (Gamma, polynomial n = 8)", qu.params(), dict(qu.values), 14.6))


def inputs(T_n):
    out = []
    for k in range(N):
        tm = (k + 0.5) * H
        out.append((V * math.cos(W * tm), V * math.sin(W * tm), T_n if k * H >= 0.6 else 0.0))
    return out


def python_step(params, u):
    best = math.inf
    for _ in range(REPEATS):
        plant, x = Plant(params), (0.0,) * N_STATES
        t0 = time.perf_counter()
        for k, (va, vb, tl) in enumerate(u):
            x = plant.step(k * H, x, va, vb, tl, H)
        best = min(best, time.perf_counter() - t0)
    return best / N


def native_step(fmu, values, u):
    from orchestration.run.fmu_instance import FMUInstance

    best = math.inf
    for _ in range(REPEATS):
        inst = FMUInstance(fmu, "bench")
        try:
            inst.set_parameters(values)
            inst.initialize(0.0)
            s = inst.slave
            vin = inst.vr(("v_s_alpha", "v_s_beta", "T_load"))
            vout = inst.vr(("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "omega_m"))
            t0 = time.perf_counter()
            for k, uk in enumerate(u):
                s.setReal(vin, list(uk))
                inst.do_step(k * H, H)
                s.getReal(vout)
            best = min(best, time.perf_counter() - t0)
        finally:
            inst.close()
    return best / N


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"), help="FMU directory (default build/fmus)")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    fmu = Path(args.fmus) / "native" / "SaturatedInductionMotor.fmu"
    rows = []
    for name, params, values, T_n in motors():
        u = inputs(T_n)
        c = native_step(fmu, values, u) if fmu.is_file() else math.nan
        rows.append((name, python_step(params, u), c))
    base_py, base_c = rows[0][1], rows[0][2]
    lines = ["## Parameter forms: the plant's per-step cost on the Gamma form (`bench/bench_forms.py`)", "",
             f"Measured {datetime.date.today().isoformat()}, Python {platform.python_version()}, "
             f"{platform.machine()}, load average {os.getloadavg()[0]:.1f} (2 cores shared); 1-s DOL start, "
             f"10000 steps of 1e-4 s, best of {REPEATS}.", "",
             "| motor | `Plant.step` [us] | vs today | native FMU step [us] | vs today |",
             "|---|---|---|---|---|"]
    for name, py, c in rows:
        lines.append(f"| {name} | {py * 1e6:.2f} | {py / base_py:.2f} | {c * 1e6:.2f} | {c / base_c:.2f} |")
    text = "\n".join(lines) + "\n\n" + (__doc__.split("\n\n", 2)[2].strip()) + "\n"
    print(text)
    if not args.no_write:
        write_section("forms", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

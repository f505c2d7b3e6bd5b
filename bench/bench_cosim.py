"""Benchmark of the co-simulation: both FMUs through the fmpy master against the plain-Python loop.

Run ``python bench/bench_cosim.py``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (the block between ``<!-- cosim:start -->`` and ``<!-- cosim:end -->``).

The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at h = Ts = 100 us, i.e. 15 000
steps of each FMU) is run through ``orchestration.master.run`` and through the plain-Python
reference (``orchestration.reference.plain_reference``, the same units without FMI), side by side,
best of 3; the two results are checked to be identical.  The ratio is the cost of FMI (pythonfmu's
wrapper, fmpy's ctypes calls, the value exchange) on top of the same Python physics.
"""

from __future__ import annotations

import datetime
import platform
import sys
from pathlib import Path

import numpy as np
from bench_plant import best_time, cpu_model, write_section

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration import fmus  # noqa: E402
from orchestration.master import run  # noqa: E402
from orchestration.reference import plain_reference  # noqa: E402
from orchestration.scenario import load_scenario  # noqa: E402


def main():
    sc = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml")
    plant, ctrl = fmus.ensure(quiet=True)
    t_co, res = best_time(run, sc, str(plant), str(ctrl))
    t_py, ref = best_time(plain_reference, sc)
    assert res.ok
    same = np.array_equal(res.frame["plant.omega_m"].to_numpy(), ref["plant.omega_m"].to_numpy())
    steps = round(sc.stop_time / sc.step)
    lines = [
        "## Co-simulation benchmark",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()}.",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| default scenario, {sc.stop_time} s simulated, {steps} steps of each FMU: fmpy master | "
        f"{t_co:.3f} s ({t_co / sc.stop_time:.3f} s per simulated second, "
        f"{1e6 * t_co / steps:.1f} us per step) |",
        f"| the same, plain Python (same units, no FMI) | {t_py:.3f} s ({t_py / sc.stop_time:.3f} s per "
        f"simulated second) |",
        f"| **ratio co-simulation / plain Python** | **{t_co / t_py:.2f}** |",
        f"| results identical | {same} |",
        "",
        "Rerun with `python bench/bench_cosim.py` (or `make bench`); it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    write_section("cosim", text)


if __name__ == "__main__":
    main()

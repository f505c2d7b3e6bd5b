"""Benchmark of the co-simulation: both FMUs through the fmpy master against the plain-Python loop,
and the whole ``run`` command with its parts.

Run ``python bench/bench_cosim.py``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (the block between ``<!-- cosim:start -->`` and ``<!-- cosim:end -->``).

(a) The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at h = Ts = 100 us, i.e. 15 000
steps of each FMU) is run through ``orchestration.master.run`` and through the plain-Python
reference (``orchestration.reference.plain_reference``, the same units without FMI), alternately,
best of 5 each; the two results are checked to be identical.  The ratio is the cost of FMI
(pythonfmu's wrapper, ctypes, the value exchange) on top of the same Python physics.

(b) ``python -m orchestration run scenarios/ramp_rated_load.yaml --out TMP --fmus DIR --no-build`` in
a child process, best of 3: its wall time against the master's ``wall_time`` (metrics.json: FMU
extraction, instantiation, the stepping loop and the streamed CSV/Parquet writes).  Its parts,
measured apart: the imports of the command (a child process that only imports), writing the
15 001 recorded rows to CSV and Parquet (``StreamingRecorder``), the metrics and the figure.

(c) cProfile of one co-simulation run: the top entries by own time.
"""

from __future__ import annotations

import cProfile
import datetime
import json
import math
import platform
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_plant import cpu_model, write_section

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration import fmus  # noqa: E402
from orchestration.master import run  # noqa: E402
from orchestration.recorder import StreamingRecorder  # noqa: E402
from orchestration.reference import plain_reference  # noqa: E402
from orchestration.results import compute_metrics, recorded_selection  # noqa: E402
from orchestration.scenario import load_scenario  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
IMPORTS = ("import orchestration.cli, orchestration.master, orchestration.results, orchestration.scenario, "
           "orchestration.plots, pyarrow.parquet")


def alternate(fns, repeats):
    """Best wall time of each function, called in turn ``repeats`` times; (times, last results)."""
    best, res = [math.inf] * len(fns), [None] * len(fns)
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            res[i] = fn()
            best[i] = min(best[i], time.perf_counter() - t0)
    return best, res


def best_of(fn, repeats=3):
    return alternate([fn], repeats)[0][0]


def run_command(fmu_dir, repeats=3):
    """Best (command wall time, its master wall_time) of the ``run`` command in a child process."""
    out = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "orchestration", "run", str(SCENARIO), "--out", d, "--fmus",
                            str(fmu_dir), "--no-build"], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
            total = time.perf_counter() - t0
            loop = json.loads((Path(d) / "ramp_rated_load" / "metrics.json").read_text())["wall_time"]
        out.append((total, loop))
    return min(out, key=lambda x: x[0] - x[1])


def profile_top(sc, plant, ctrl, n=10):
    pr = cProfile.Profile()
    pr.enable()
    run(sc, plant, ctrl)
    pr.disable()
    st = pstats.Stats(pr)
    total = sum(v[2] for v in st.stats.values())
    rows = sorted(st.stats.items(), key=lambda kv: -kv[1][2])[:n]
    lines = ["| function | calls | own time | share |", "|---|---|---|---|"]
    for (file, line, name), (_, calls, tt, _, _) in rows:
        where = Path(file).name if file != "~" else ""
        lines.append(f"| `{where}:{line}({name})` | {calls} | {tt:.3f} s | {100 * tt / total:.0f} % |")
    return lines, total


def main():
    sc = load_scenario(SCENARIO)
    fmu_dir = fmus.DEFAULT_DIR if Path(fmus.DEFAULT_DIR).is_absolute() else ROOT / fmus.DEFAULT_DIR
    plant, ctrl = (str(p) for p in fmus.ensure(fmu_dir, quiet=True))
    (t_co, t_py), (res, ref) = alternate([lambda: run(sc, plant, ctrl), lambda: plain_reference(sc)], 5)
    assert res.ok
    same = all(np.array_equal(res.frame[c].to_numpy(), ref[c].to_numpy()) for c in ref.columns)
    steps = round(sc.stop_time / sc.step)

    total, loop = run_command(fmu_dir)
    t_imp = best_of(lambda: subprocess.run([sys.executable, "-c", IMPORTS], cwd=ROOT, check=True))
    t_py0 = best_of(lambda: subprocess.run([sys.executable, "-c", "pass"], check=True))
    df = res.frame
    keep = recorded_selection(sc, list(df.columns))
    arr = df.to_numpy()

    def write_files():
        with tempfile.TemporaryDirectory() as d:
            rec = StreamingRecorder(list(df.columns), d, keep=keep)
            rec.rows = [tuple(r) for r in arr.tolist()]
            rec.close()

    t_files = best_of(write_files)
    data = {c: df[c].to_numpy() for c in df.columns}
    t_metrics = best_of(lambda: compute_metrics(data, sc))
    from orchestration.plots import figure

    with tempfile.TemporaryDirectory() as d:
        t_fig = best_of(lambda: figure(data, Path(d) / "figure.png", "bench"))
    prof, prof_total = profile_top(sc, plant, ctrl)

    lines = [
        "## Co-simulation benchmark",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()}.",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| (a) default scenario, {sc.stop_time} s simulated, {steps} steps of each FMU: fmpy master | "
        f"{t_co:.3f} s ({t_co / sc.stop_time:.3f} s per simulated second, "
        f"{1e6 * t_co / steps:.1f} us per step) |",
        f"| (a) the same, plain Python (same units, no FMI) | {t_py:.3f} s ({t_py / sc.stop_time:.3f} s per "
        f"simulated second, {1e6 * t_py / steps:.1f} us per step) |",
        f"| **(a) ratio co-simulation / plain Python** | **{t_co / t_py:.2f}** |",
        f"| (a) results identical (every column) | {same} |",
        f"| (b) `run` command, whole (child process) | {total:.3f} s |",
        f"| (b) its master `wall_time` (extraction, instantiation, loop, CSV/Parquet) | {loop:.3f} s |",
        f"| **(b) command overhead beyond `wall_time`** | **{total - loop:.3f} s** |",
        f"| (b) part: Python start-up (`python -c pass`) | {t_py0:.3f} s |",
        f"| (b) part: imports of the command (start-up included) | {t_imp:.3f} s |",
        f"| (b) part: CSV + Parquet of the {len(df)} rows (inside `wall_time`) | {t_files:.3f} s |",
        f"| (b) part: metrics | {t_metrics:.3f} s |",
        f"| (b) part: figure | {t_fig:.3f} s |",
        "",
        f"(c) cProfile of one co-simulation run ({prof_total:.2f} s under the profiler), top entries by own "
        "time (a ctypes call into an FMU counts in its caller, `_loop`, less the Python it runs):",
        "",
        *prof,
        "",
        "Rerun with `python bench/bench_cosim.py` (or `make bench`); it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    write_section("cosim", text)


if __name__ == "__main__":
    main()

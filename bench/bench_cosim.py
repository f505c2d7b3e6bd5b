"""Benchmark of the co-simulation: both FMUs through the fmpy master against the plain-Python loop,
and the whole ``run`` command with its parts.

Run ``python -m bench cosim``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (the block between ``<!-- cosim:start -->`` and ``<!-- cosim:end -->``).

(a) The default scenario (``scenarios/ramp_rated_load.yaml``: 1.5 s at h = Ts = 100 us, i.e. 15 000
steps of each FMU) is run through ``orchestration.run.master.run`` and through the plain-Python
reference (``orchestration.run.reference.plain_reference``, the same units without FMI), alternately,
best of 5 each; the two results are checked to be identical.  The ratio is the cost of FMI
(pythonfmu's wrapper, ctypes, the value exchange) on top of the same Python physics.

The floor, in the same rounds: the same master stepping two pythonfmu FMUs with the variables of
ours (names, value references, causalities, types) whose doStep does nothing and whose get/set
return zeros or ignore the values (``bench/floor_fmus.py``, built into a temporary directory for
this run, never shipped).  That is what pythonfmu's C++ wrapper, fmpy's ctypes and the master cost
per step before any code of ours runs in an FMU, so ``(plain + floor) / plain`` is the best ratio
any glue and physics could reach with pythonfmu.

``--compare DIR``: another checkout of this project (its own ``.venv`` and FMUs built from its own
sources in ``DIR/build/fmus``, e.g. the main checkout as "before") is measured in the same rounds,
alternating child processes (pythonfmu FMUs of two builds cannot share one interpreter), best of
``--rounds`` x 3 runs each of the co-simulation and the plain loop, with the digests of the results.

(b) ``python -m orchestration run scenarios/ramp_rated_load.yaml --out TMP --fmus build/fmus --no-build``
in a child process (the checkout's interpreter, in its directory), best of 5, with and without
``--no-plot``: its wall time against its stepping loop (``master._loop``, timed inside the child by
a wrapper that calls the command's ``main``) and against the master's ``wall_time`` (metrics.json:
FMU extraction, instantiation, the loop and the streamed CSV/Parquet writes); the CPU time of the
command's whole process tree (the figure helper included).  ``--compare DIR`` measures another
checkout (its ``.venv``, its FMUs in ``DIR/build/fmus``) in the same rounds, alternating.  Parts of
this checkout, measured apart: the imports of the command, writing the 15 001 recorded rows to CSV
and Parquet (``StreamingRecorder``), the metrics, importing matplotlib and the figure.

(c) cProfile of one co-simulation run: the top entries by own time.
"""

from __future__ import annotations

import argparse
import cProfile
import datetime
import json
import math
import os
import platform
import pstats
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import floor_fmus
from bench.common import cpu_model, git_head, interpreter, write_section

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from orchestration.packaging import fmus  # noqa: E402
from orchestration.results.recorder import StreamingRecorder  # noqa: E402
from orchestration.results.writer import compute_metrics  # noqa: E402
from orchestration.run.master import run  # noqa: E402
from orchestration.run.reference import plain_reference  # noqa: E402
from orchestration.scenario.load import load_scenario  # noqa: E402
from orchestration.scenario.recording import recorded_selection  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
# what the command imports itself (no matplotlib)
IMPORTS = ("import orchestration.cli.commands, orchestration.run.master, orchestration.results.writer, "
           "orchestration.scenario.load, orchestration.results.figure_process, pyarrow.parquet")
MPL_IMPORT = ("import time, orchestration.cli.commands, orchestration.run.master, "
              "orchestration.results.writer, "
              "pyarrow.parquet\n"
              "t0 = time.perf_counter()\nimport orchestration.results.plots\nprint(time.perf_counter() - t0)")


def alternate(fns, repeats, cpu=None):
    """Best wall time of each function, called in turn ``repeats`` times; (times, last results).
    ``cpu``: a list that receives the best CPU time (``time.process_time``) of each."""
    best, res, best_cpu = [math.inf] * len(fns), [None] * len(fns), [math.inf] * len(fns)
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0, c0 = time.perf_counter(), time.process_time()
            res[i] = fn()
            best[i] = min(best[i], time.perf_counter() - t0)
            best_cpu[i] = min(best_cpu[i], time.process_time() - c0)
    if cpu is not None:
        cpu[:] = best_cpu
    return best, res


# run in the checkout measured (cwd), with that checkout's interpreter: only APIs every checkout has
CHILD = r"""
import hashlib, json, sys, time
from orchestration.packaging import fmus
from orchestration.run.master import run
from orchestration.run.reference import plain_reference
from orchestration.scenario.load import load_scenario

repeats = int(sys.argv[1])
sc = load_scenario("scenarios/ramp_rated_load.yaml")
plant, ctrl = (str(p) for p in fmus.paths("build/fmus"))
out = {k: float("inf") for k in ("cosim", "plain", "cosim_cpu", "plain_cpu")}
for _ in range(repeats):
    for k, fn in (("cosim", lambda: run(sc, plant, ctrl)), ("plain", lambda: plain_reference(sc))):
        t0, c0 = time.perf_counter(), time.process_time()
        r = fn()
        out[k] = min(out[k], time.perf_counter() - t0)
        out[k + "_cpu"] = min(out[k + "_cpu"], time.process_time() - c0)
        if k == "cosim":
            assert r.ok, r.message
            res = r.frame
        else:
            ref = r
h = hashlib.sha256()
for c in ref.columns:
    h.update(c.encode() + b"\0" + res[c].to_numpy().tobytes())
out["digest"] = h.hexdigest()
out["same"] = all((res[c].to_numpy() == ref[c].to_numpy()).all() for c in ref.columns)
print(json.dumps(out))
"""


def measure_checkout(root, repeats):
    """Best co-simulation and plain-loop times of the checkout ``root`` in a child process (no
    bytecode written into it)."""
    r = subprocess.run([interpreter(root), "-c", CHILD, str(repeats)], cwd=root, capture_output=True,
                       text=True, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
    if r.returncode != 0:
        raise SystemExit(f"{root}: the measuring child failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def compare(other, rounds, repeats=3):
    """``{name: best times}`` of the checkout ``other`` ("before") and this one ("after"), measured
    alternately in child processes; the digests of their results."""
    checkouts = {"before": Path(other).resolve(), "after": ROOT}
    missing = [p for p in fmus.paths(checkouts["before"] / "build" / "fmus") if not p.exists()]
    if missing:
        raise SystemExit(f"--compare {other}: no {missing[0].name} in its build/fmus (build it there with "
                         "its own interpreter: python -m orchestration build)")
    best = {}
    for _ in range(rounds):
        for name, root in checkouts.items():
            out = measure_checkout(root, repeats)
            old = best.setdefault(name, out)
            for k in ("cosim", "plain", "cosim_cpu", "plain_cpu"):
                old[k] = min(old[k], out[k])
            old["same"] = old["same"] and out["same"]
            old.setdefault("digests", set()).add(out["digest"])
    for name, root in checkouts.items():
        best[name]["head"] = git_head(root)
    return best


def compare_lines(best, steps):
    b, a = best["before"], best["after"]
    same = len(b["digests"] | a["digests"]) == 1

    def us(x):
        return f"{1e6 * x / steps:.1f} us/step"

    return [
        "Before / after, measured in one run (`--compare DIR`): \"before\" is commit "
        f"`{b['head']}`, \"after\" `{a['head']}` (this checkout), each with FMUs built from its own "
        "sources; child processes alternating, best of all rounds.",
        "",
        "| default scenario | before | after |",
        "|---|---|---|",
        f"| co-simulation, `master.run` | {us(b['cosim'])} | {us(a['cosim'])} |",
        f"| plain Python, `plain_reference` | {us(b['plain'])} | {us(a['plain'])} |",
        f"| **ratio co-simulation / plain (wall)** | **{b['cosim'] / b['plain']:.2f}** | "
        f"**{a['cosim'] / a['plain']:.2f}** |",
        f"| ratio co-simulation / plain (CPU time) | {b['cosim_cpu'] / b['plain_cpu']:.2f} | "
        f"{a['cosim_cpu'] / a['plain_cpu']:.2f} |",
        f"| co-simulation = plain, every column | {b['same']} | {a['same']} |",
        f"| before and after results identical (SHA-256 of every column) | {same} | |",
        "",
    ]


def best_of(fn, repeats=3):
    return alternate([fn], repeats)[0][0]


# the run command as ``python -m orchestration`` runs it, with its stepping loop timed
WRAPPED = r"""
import json, sys, time
import orchestration.run.master as m
loop = m._loop
spent = []
def timed(*a, **k):
    t0 = time.perf_counter()
    try:
        return loop(*a, **k)
    finally:
        spent.append(time.perf_counter() - t0)
m._loop = timed
from orchestration.cli.commands import main
code = main(sys.argv[1:])
print("LOOP", json.dumps(spent[0]))
sys.exit(code)
"""


def run_command(root, *extra):
    """(command wall time, its stepping loop, its master wall_time, CPU time of its process tree)."""
    with tempfile.TemporaryDirectory() as d:
        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        args = ["run", str(SCENARIO.relative_to(ROOT)), "--out", d, "--fmus", "build/fmus", "--no-build",
                *extra]
        r = subprocess.run([interpreter(root), "-c", WRAPPED, *args], cwd=root, check=True,
                           capture_output=True, text=True)
        total = time.perf_counter() - t0
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        loop = json.loads(r.stdout.split("LOOP", 1)[1])
        wall = json.loads((Path(d) / "ramp_rated_load" / "metrics.json").read_text())["wall_time"]
    return total, loop, wall, (c1.ru_utime + c1.ru_stime) - (c0.ru_utime + c0.ru_stime)


def command_rounds(checkouts, repeats=5):
    """{(checkout, plot): best (total, loop, wall, cpu)}, the checkouts and modes alternating;
    "best" is the run with the least time beyond its loop."""
    best = {}
    for _ in range(repeats):
        for plot in (True, False):
            for name, root in checkouts.items():
                m = run_command(root, *([] if plot else ["--no-plot"]))
                key = (name, plot)
                if key not in best or m[0] - m[1] < best[key][0] - best[key][1]:
                    best[key] = m
    return best


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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--compare", metavar="DIR", help="another checkout, measured in (a) and (b)")
    ap.add_argument("--rounds", type=int, default=5, help="rounds of (a) with --compare (default 5)")
    ap.add_argument("--repeats", type=int, default=5, help="rounds of (b) (default 5)")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)
    sc = load_scenario(SCENARIO)
    fmu_dir = fmus.DEFAULT_DIR if Path(fmus.DEFAULT_DIR).is_absolute() else ROOT / fmus.DEFAULT_DIR
    plant, ctrl = (str(p) for p in fmus.ensure(fmu_dir, quiet=True))
    cpu = []
    with tempfile.TemporaryDirectory(prefix="satmotor-floor-") as floor_dir:
        floor_p, floor_c = (str(p) for p in floor_fmus.build(floor_dir, Path(plant).parent))
        fns = [lambda: run(sc, plant, ctrl), lambda: run(sc, floor_p, floor_c), lambda: plain_reference(sc)]
        (t_co, t_floor, t_py), (res, res_floor, ref) = alternate(fns, 5, cpu)
    assert res.ok and res_floor.ok, (res.message, res_floor.message)
    same = all(np.array_equal(res.frame[c].to_numpy(), ref[c].to_numpy()) for c in ref.columns)
    steps = round(sc.stop_time / sc.step)
    attainable = (t_py + t_floor) / t_py
    c_co, c_floor, c_py = cpu
    verdict = ("reachable" if attainable <= 1.3 else
               f"**not reachable with pythonfmu**: the floor alone is {1e6 * t_floor / steps:.1f} us per "
               f"step, more than 0.3 x plain = {0.3e6 * t_py / steps:.1f} us")
    before_after = compare(args.compare, args.rounds) if args.compare else None

    checkouts = {"this": ROOT}
    if args.compare:
        checkouts = {"before": Path(args.compare).resolve(), "this": ROOT}
    heads = {n: subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=r, capture_output=True,
                               text=True).stdout.strip() for n, r in checkouts.items()}
    load0 = os.getloadavg()[0]
    cmd = command_rounds(checkouts, args.repeats)
    load1 = os.getloadavg()[0]
    t_imp = best_of(lambda: subprocess.run([sys.executable, "-c", IMPORTS], cwd=ROOT, check=True))
    t_py0 = best_of(lambda: subprocess.run([sys.executable, "-c", "pass"], check=True))
    t_mpl = min(float(subprocess.run([sys.executable, "-c", MPL_IMPORT], cwd=ROOT, check=True,
                                     capture_output=True, text=True).stdout) for _ in range(3))
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
    from orchestration.results.plots import figure

    with tempfile.TemporaryDirectory() as d:
        t_fig = best_of(lambda: figure(data, Path(d) / "figure.png", "bench"))
    prof, prof_total = profile_top(sc, plant, ctrl)
    names = list(checkouts)

    def row(label, fn, bold=False):
        b = "**" if bold else ""
        return f"| {b}{label}{b} | " + " | ".join(f"{b}{fn(n)}{b}" for n in names) + " |"

    lines = [
        "## Co-simulation benchmark",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()} "
        f"({os.cpu_count()} cores, shared: load average {load0:.1f} before (b), {load1:.1f} after).",
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
        f"| (a) floor: the same master stepping two do-nothing pythonfmu FMUs with our FMUs' variables | "
        f"{t_floor:.3f} s ({1e6 * t_floor / steps:.1f} us per step) |",
        f"| (a) co-simulation beyond the floor (our glue and physics inside the FMUs) | "
        f"{1e6 * (t_co - t_floor) / steps:.1f} us per step (plain Python: {1e6 * t_py / steps:.1f}) |",
        f"| **(a) best ratio attainable with pythonfmu, (plain + floor) / plain** | **{attainable:.2f}** |",
        f"| (a) target ratio 1.3 | {verdict} |",
        f"| (a) the same ratios in CPU time (co-simulation / plain; best attainable) | {c_co / c_py:.2f}; "
        f"{(c_py + c_floor) / c_py:.2f} |",
        "",
        f"(b) the `run` command in a child process, best of {args.repeats}"
        + (", the checkouts alternating" if len(names) > 1 else "") + ":",
        "",
        "| (b) `run` command | " + " | ".join(f"{n} `{heads[n]}`" for n in names) + " |",
        "|---|" + "---|" * len(names),
        row("whole command (wall time)", lambda n: f"{cmd[n, True][0]:.3f} s"),
        row("its stepping loop (`master._loop`)", lambda n: f"{cmd[n, True][1]:.3f} s"),
        row("its master `wall_time` (extraction, instantiation, loop, CSV/Parquet)",
            lambda n: f"{cmd[n, True][2]:.3f} s"),
        row("command beyond its stepping loop", lambda n: f"{cmd[n, True][0] - cmd[n, True][1]:.3f} s", True),
        row("command beyond `wall_time`", lambda n: f"{cmd[n, True][0] - cmd[n, True][2]:.3f} s", True),
        row("CPU time of the command's process tree", lambda n: f"{cmd[n, True][3]:.3f} s"),
        row("with `--no-plot`: beyond its stepping loop",
            lambda n: f"{cmd[n, False][0] - cmd[n, False][1]:.3f} s"),
        row("with `--no-plot`: CPU time of the process tree", lambda n: f"{cmd[n, False][3]:.3f} s"),
        "",
        "Parts of this checkout, measured apart:",
        "",
        "| (b) part | value |",
        "|---|---|",
        f"| Python start-up (`python -c pass`) | {t_py0:.3f} s |",
        f"| imports of the command (start-up included; matplotlib is imported by the figure helper) | "
        f"{t_imp:.3f} s |",
        f"| importing `orchestration.results.plots` (matplotlib) after those | {t_mpl:.3f} s |",
        f"| CSV + Parquet of the {len(df)} rows (inside `wall_time`) | {t_files:.3f} s |",
        f"| metrics | {t_metrics:.3f} s |",
        f"| figure (drawing and PNG) | {t_fig:.3f} s |",
        "",
        f"(c) cProfile of one co-simulation run ({prof_total:.2f} s under the profiler), top entries by own "
        "time (a ctypes call into an FMU counts in its caller, `_loop`, less the Python it runs):",
        "",
        *prof,
        "",
        *(compare_lines(before_after, steps) if before_after else []),
        "Rerun with `python -m bench cosim` (or `make bench`; `--compare DIR` adds another "
        "checkout to (a) and (b)); it rewrites this section.",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("cosim", text)


if __name__ == "__main__":
    main()

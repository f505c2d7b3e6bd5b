"""The whole ``run --no-plot`` command of the default scenario as a process (start-up, imports, checks,
the run, the files) against the C floor's stepping of the same 15 000 steps, side by side.

Run ``python -m bench startup [--rounds N] [--no-write]``; prints a table and rewrites its section
of ``bench/RESULTS.md`` (between ``<!-- startup:start -->`` and ``<!-- startup:end -->``) unless
``--no-write``.  Rounds alternate; CPU of each child (``RUSAGE_CHILDREN``: user + system), best and
median of N (default 5), the load average before and after:

* the C floor (``bench/floor_master.c``): 15 000 Gauss-Seidel steps of the native FMI 2.0 FMUs, nothing
  recorded, the loop only;
* ``python -m orchestration run FILE --no-plot --no-build --engine c`` and ``--engine fmpy``, FILE the
  default scenario as the library has it (``record`` full: ``timeseries.csv`` and ``.parquet``
  written) and at ``record: metrics``;
* ``python -c pass`` and ``python -c "import numpy"`` (also with ``OPENBLAS_NUM_THREADS=1``, as the
  CLI sets it): what any Python process with numpy pays;
* with ``--compare DIR``: the same commands run from the checkout ``DIR`` (before / after).

The children run with bytecode caching on (``PYTHONDONTWRITEBYTECODE`` removed from their
environment, one warm-up run first), as an installed package runs.  Then ``-X importtime`` of the
``--engine c`` command at ``record: metrics``: the self time of its imports summed by top package.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import cpu_model, git_head, write_section  # noqa: E402
from bench.floor_host import build_floor, floor_args, run_floor, unit  # noqa: E402
from orchestration.packaging import fmus  # noqa: E402

SCENARIO = ROOT / "scenarios" / "ramp_rated_load.yaml"
STEPS = 15_000  # the default scenario: 1.5 s at 100 us
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def child_cpu(args, cwd=ROOT, env=None):
    """``(CPU [s] (user + system), stderr)`` of the child process ``args`` run in ``cwd`` (``python -m
    orchestration`` there runs that checkout's package)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True, env={**ENV, **(env or {})})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 3):  # 3: acceptance missed, still a complete run
        raise SystemExit(f"{' '.join(map(str, args))} failed ({done.returncode}): {done.stderr}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done.stderr


def run_args(yaml, out, fmu_dir, engine, *options):
    """The ``run`` command line; ``options``: Python's own (``-X importtime``)."""
    return [sys.executable, *options, "-m", "orchestration", "run", str(yaml), "--out", str(out),
            "--fmus", str(fmu_dir), "--no-build", "--no-plot", "--engine", engine]


def imports_by_package(text):
    """``[(self time [ms], top package)]`` of a ``-X importtime`` printout, largest first."""
    total = {}
    for line in text.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        self_us, _, name = line[len("import time:"):].split("|")
        us, root = int(self_us), name.strip().split(".")[0]
        total[root] = total.get(root, 0) + us
    return sorted(((us / 1e3, k) for k, us in total.items()), reverse=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--compare", metavar="DIR", help="also run the commands of the checkout DIR (its "
                    "orchestration and satmotor packages, this environment): before / after side by side")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    fmi2 = list(map(str, fmus.paths(a.fmus, "native")))
    load0 = os.getloadavg()
    cpu = {}
    with tempfile.TemporaryDirectory(prefix="bench_startup_") as tmp:
        work = Path(tmp)
        floor_exe = build_floor(work)
        floor_units = unit(fmi2[0], work), unit(fmi2[1], work)
        metrics = work / "ramp_rated_load_metrics.yaml"
        metrics.write_text(SCENARIO.read_text().replace("name: ramp_rated_load", "name: ramp_metrics")
                           .replace("record:", "record:\n  level: metrics", 1))
        trees = {"": ROOT, **({f" ({Path(a.compare).name})": Path(a.compare).resolve()} if a.compare else {})}
        cases = {f"run --engine {e} --no-plot, record {lvl}{tag}": (f, e, tree)
                 for lvl, f in (("full", SCENARIO), ("metrics", metrics)) for e in ("c", "fmpy")
                 for tag, tree in trees.items()}
        for f, e, tree in cases.values():  # warm-up: bytecode written, the engine compiled, the FMUs prepared
            child_cpu(run_args(f, work / "out", a.fmus, e), tree)
        for r in range(a.rounds):
            _, c, _ = run_floor(floor_args(floor_exe, *floor_units, STEPS, "floor"))
            cpu.setdefault("floor", []).append(c)
            cpu.setdefault("python -c pass", []).append(child_cpu([sys.executable, "-c", "pass"])[0])
            cpu.setdefault("python -c 'import numpy'", []).append(
                child_cpu([sys.executable, "-c", "import numpy"])[0])
            cpu.setdefault("OPENBLAS_NUM_THREADS=1 python -c 'import numpy'", []).append(
                child_cpu([sys.executable, "-c", "import numpy"], env={"OPENBLAS_NUM_THREADS": "1"})[0])
            for name, (f, e, tree) in cases.items():
                cpu.setdefault(name, []).append(child_cpu(run_args(f, work / "out", a.fmus, e), tree)[0])
            print(f"round {r + 1}/{a.rounds}: " + ", ".join(f"{k} {min(v):.3f}" for k, v in cpu.items())
                  + " s CPU (best so far)", flush=True)
        _, err = child_cpu(run_args(metrics, work / "out", a.fmus, "c", "-X", "importtime"))
    load1 = os.getloadavg()
    floor = min(cpu["floor"])
    lines = [f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {cpu_model()}, "
             f"{platform.python_version()}, commit {git_head(ROOT)}, load {load0[0]:.2f} -> {load1[0]:.2f}",
             "", "| process | CPU [s] best (median) | best / floor's stepping |", "|---|---:|---:|"]
    for name, v in cpu.items():
        label = "C floor, 15 000 steps, the loop only" if name == "floor" else f"`{name}`"
        lines.append(f"| {label} | {min(v):.3f} ({statistics.median(v):.3f}) | {min(v) / floor:.1f}x |")
    top = imports_by_package(err)[:10]
    lines += ["", "Imports of `run --engine c --no-plot` at record metrics (`-X importtime`, self time "
              "summed by top package, ms): " + ", ".join(f"{k} {ms:.0f}" for ms, k in top) + "."]
    text = ("## startup: the whole `run --no-plot` process against the floor\n\n" + "\n".join(lines) + "\n\n"
            "`python -m bench startup`: CPU of each child process (getrusage), rounds alternating, "
            f"{a.rounds} rounds; bytecode caching on in the children.")
    print(text)
    if not a.no_write:
        write_section("startup", text)


if __name__ == "__main__":
    main()

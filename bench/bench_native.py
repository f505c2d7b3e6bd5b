"""Benchmark of the three FMU variants under the fmpy master, side by side in one run: pythonfmu
(FMI 2.0), native C FMI 2.0 and native C FMI 3.0, on the default scenario.

Run ``python -m bench native``; prints the numbers and replaces its own section of
``bench/RESULTS.md`` (between ``<!-- native:start -->`` and ``<!-- native:end -->``).
``--compare DIR`` also measures another checkout of this project (e.g. an older commit made with
``git worktree add DIR COMMIT``, with its own ``.venv`` and its FMUs built from its own sources in
``DIR/build/fmus``) in the same rounds, so "before" and "after" see the same machine load.
``--no-write`` leaves RESULTS.md alone.

What is measured: ``orchestration.run.master.run`` of ``scenarios/ramp_rated_load.yaml`` (1.5 s at
h = Ts = 100 us: 15 000 steps of each FMU, every step recorded, in memory), wall time including the
FMU extraction and instantiation of the run, and its CPU time (``time.process_time``: on a shared
machine the time the process waited for a core is in the wall time only, so the CPU times give
the steadier ratios; on an idle machine the two agree).  Each measurement is a child process (a fresh
interpreter: pythonfmu FMUs share one interpreter per process) running the scenario ``--repeats``
times and keeping its best; the rounds alternate variants and checkouts and the table keeps the
best of all rounds.  Every child returns a SHA-256 of its recorded columns: the variants of a
checkout must give bit-identical results (two checkouts may differ on purpose: the table says).
Last, one child per checkout runs the native FMI 2.0 variant under cProfile (top entries by own
time; a ctypes call into an FMU has no Python frame, so its time counts in its caller,
``master._loop``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

from bench.common import cpu_model, git_head, interpreter, write_section

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ("python", "native", "native-fmi3")
LABELS = {"python": "pythonfmu (FMI 2.0)", "native": "native C, FMI 2.0", "native-fmi3": "native C, FMI 3.0"}

# run in the checkout measured (cwd), with that checkout's interpreter: only APIs every checkout has
CHILD = r"""
import cProfile, hashlib, json, pstats, sys, time
from pathlib import Path
try:
    from orchestration.packaging import fmus
    from orchestration.run.master import run
    from orchestration.scenario.load import load_scenario
except ImportError:  # a checkout from before orchestration/ was split by job
    from orchestration import fmus
    from orchestration.master import run
    from orchestration.scenario import load_scenario

variant, repeats, profile = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
sc = load_scenario("scenarios/ramp_rated_load.yaml")
plant, ctrl = (str(p) for p in fmus.paths("build/fmus", variant))
best = cpu = float("inf")
for _ in range(repeats):
    t0, c0 = time.perf_counter(), time.process_time()
    res = run(sc, plant, ctrl)
    best, cpu = min(best, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
assert res.ok, res.message
h = hashlib.sha256()
for name, a in res.recorder.arrays().items():
    h.update(name.encode() + b"\0" + a.tobytes())
out = {"best": best, "cpu": cpu, "steps": round(sc.stop_time / sc.step), "stop_time": sc.stop_time,
       "digest": h.hexdigest()}
if profile:
    pr = cProfile.Profile()
    pr.enable()
    run(sc, plant, ctrl)
    pr.disable()
    st = pstats.Stats(pr)
    total = sum(v[2] for v in st.stats.values())
    top = sorted(st.stats.items(), key=lambda kv: -kv[1][2])[:8]
    out["profile_total"] = total
    out["profile"] = [[Path(f).parent.name + "/" + Path(f).name if f != "~" else "", line, fn, calls, tt]
                      for (f, line, fn), (_, calls, tt, _, _) in top]
print(json.dumps(out))
"""


def measure(root, variant, repeats, profile=False):
    r = subprocess.run([interpreter(root), "-c", CHILD, variant, str(repeats), "1" if profile else "0"],
                       cwd=root, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{root} {variant}: the measuring child failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def load():
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "?"


def profile_table(prof, total):
    lines = ["| function | calls | own time | share |", "|---|---|---|---|"]
    for where, line, fn, calls, tt in prof:
        lines.append(f"| `{where}:{line}({fn})` | {calls} | {tt:.3f} s | {100 * tt / total:.0f} % |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds (default 5)")
    ap.add_argument("--repeats", type=int, default=2, help="runs per child, best kept (default 2)")
    ap.add_argument("--compare", metavar="DIR", help="another checkout to measure in the same rounds")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    args = ap.parse_args(argv)

    sys.path.insert(0, str(ROOT))
    from orchestration.packaging import fmus

    fmus.ensure(ROOT / "build" / "fmus", quiet=True)
    checkouts = {"this": ROOT}
    if args.compare:
        other = Path(args.compare).resolve()
        built = other / "build" / "fmus"
        missing = [v for v in VARIANTS if not all(p.exists() for p in fmus.paths(built, v))]
        if missing:
            raise SystemExit(f"--compare {other}: no FMUs of {', '.join(missing)} in {other / 'build/fmus'} "
                             "(build them there with its own interpreter: python -m orchestration build)")
        checkouts = {"before": other, "this": ROOT}
    heads = {name: git_head(root) for name, root in checkouts.items()}
    load0 = load()
    best, cpu, digests, info = {}, {}, {}, {}
    for r in range(args.rounds):
        for v in VARIANTS:
            for name, root in checkouts.items():
                out = measure(root, v, args.repeats)
                best[name, v] = min(best.get((name, v), float("inf")), out["best"])
                cpu[name, v] = min(cpu.get((name, v), float("inf")), out["cpu"])
                digests.setdefault(name, set()).add(out["digest"])
                info = out
        k = 1e6 / info["steps"]
        now = ", ".join(f"{n} {v} {k * best[n, v]:.1f}/{k * cpu[n, v]:.1f}"
                        for n in checkouts for v in VARIANTS)
        print(f"round {r + 1}/{args.rounds} (best so far, wall/CPU us/step): {now}", flush=True)
    load1 = load()
    profiles = {name: measure(root, "native", 1, profile=True) for name, root in checkouts.items()}
    steps, stop = info["steps"], info["stop_time"]

    def us(name, v, table=cpu):
        return 1e6 * table[name, v] / steps

    names = list(checkouts)
    head = "| variant | " + " | ".join(f"{n} `{heads[n]}`: CPU (wall) [us/step]" for n in names) + " | " + \
        " | ".join(f"{n}: faster than pythonfmu, CPU (wall)" for n in names) + " |"
    lines = [
        "## Native FMUs under the fmpy master: the three variants side by side",
        "",
        f"Measured {datetime.date.today()}, Python {platform.python_version()}, CPU: {cpu_model()} "
        f"({os.cpu_count()} cores, shared: load average {load0} at the start, {load1} at the end).",
        "",
        f"Default scenario ({stop} s simulated, {steps} steps of each FMU, every step recorded, in memory), "
        f"`orchestration.run.master.run`, best of {args.rounds} alternating rounds x {args.repeats} runs, "
        "one child process per measurement.",
        "",
        head,
        "|---|" + "---|" * (2 * len(names)),
    ]
    for v in VARIANTS:
        times = " | ".join(f"{us(n, v):.1f} ({us(n, v, best):.1f})" for n in names)
        ratios = " | ".join(f"**{us(n, 'python') / us(n, v):.2f}x** "
                            f"({us(n, 'python', best) / us(n, v, best):.2f}x)" for n in names)
        lines.append(f"| {LABELS[v]} | {times} | {ratios} |")
    lines += [
        "",
        "| wall seconds per simulated second | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(names),
        *(f"| {LABELS[v]} | " + " | ".join(f"{best[n, v] / stop:.3f}" for n in names) + " |"
          for v in VARIANTS),
        "",
        "Results bit-identical across the three variants (SHA-256 of every recorded column): "
        + ", ".join(f"{n} {'yes' if len(digests[n]) == 1 else 'NO'}" for n in names)
        + (f"; the same in both checkouts: {'yes' if len(set().union(*digests.values())) == 1 else 'no'}"
           if len(names) > 1 else "") + ".",
        "",
    ]
    for name in names:
        p = profiles[name]
        lines += [f"cProfile of one native FMI 2.0 run, {name} (`{heads[name]}`, {p['profile_total']:.2f} s "
                  "under the profiler; the FMI calls count in `master._loop`):", "",
                  *profile_table(p["profile"], p["profile_total"]), ""]
    lines.append("Rerun with `python -m bench native` (or `make bench`; `--compare DIR` adds another "
                 "checkout); it rewrites this section.")
    text = "\n".join(lines)
    print(text)
    consistent = all(len(d) == 1 for d in digests.values())
    if not consistent:
        print("the results differ between the variants of one checkout", file=sys.stderr)
    if not args.no_write:
        write_section("native", text)
    return 0 if consistent else 1


if __name__ == "__main__":
    sys.exit(main())

"""A Monte Carlo study of the default scenario on a 2-worker dask.distributed cluster against the local
``batch --jobs 2``, CPU of the whole process tree, side by side in one run.

Run ``python -m bench dask [--samples N] [--rounds R] [--no-write]``; prints a table and rewrites its
section of ``bench/RESULTS.md`` unless ``--no-write``.  The study is ``bench montecarlo``'s (the default
scenario at ``record: metrics``, four plant parameters drawn, native FMUs, ``--no-plot``).  The local
side: ``batch STUDY --jobs 2`` (``RUSAGE_CHILDREN`` of the whole tree).  The Dask side: a
``LocalCluster`` of 2 worker processes (1 thread each, nannies) on 127.0.0.1 started before the
timing; counted are the batch's tree (``RUSAGE_CHILDREN``) plus the CPU this process (the scheduler
and the nannies run in it), the workers and the workers' children (the runs, waited for by their
worker) spent during the batch (psutil, before and after).  Rounds are interleaved (local, Dask,
local, ...); the ratio is of the sums.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.bench_montecarlo import batch, study_file  # noqa: E402
from bench.common import measured, write_section  # noqa: E402


def _tree_cpu(pids):
    """CPU [s] of the processes ``pids`` and of their children they waited for."""
    import psutil

    total = 0.0
    for pid in pids:
        try:
            t = psutil.Process(pid).cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += t.user + t.system + t.children_user + t.children_system
    return total


def _self_cpu():
    """CPU [s] of this process: the scheduler and the nannies run in its event loop."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=200, help="variants of the study (default 200)")
    ap.add_argument("--rounds", type=int, default=1, help="interleaved rounds (default 1)")
    ap.add_argument("--fmus", default=str(ROOT / "build" / "fmus"))
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    from distributed import Client, LocalCluster

    load0 = os.getloadavg()[0]
    cpu = {"local": 0.0, "dask": 0.0}
    wall = {"local": 0.0, "dask": 0.0}
    with tempfile.TemporaryDirectory(prefix="bench_dask_") as tmp, \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                         dashboard_address=None) as cluster, Client(cluster) as client:
        work = Path(tmp)
        path = study_file(work, a.samples)
        pids = list(client.run(os.getpid).values())  # the worker processes (scheduler, nannies: here)
        for r in range(a.rounds):
            c, w = batch(path, work / f"local{r}", a.fmus, 2)
            cpu["local"] += c
            wall["local"] += w
            t0, s0 = _tree_cpu(pids), _self_cpu()
            c, w = batch(path, work / f"dask{r}", a.fmus, 2, "--scheduler", cluster.scheduler_address)
            cpu["dask"] += c + _tree_cpu(pids) - t0 + _self_cpu() - s0
            wall["dask"] += w
        client.close()
    n = a.samples * a.rounds
    ratio = cpu["dask"] / cpu["local"]
    rows = [("local `batch --jobs 2`", cpu["local"] / n, wall["local"] / a.rounds),
            ("Dask, 2 local workers", cpu["dask"] / n, wall["dask"] / a.rounds)]
    table = ["| | CPU per variant [ms] | wall per study [s] |", "|---|---:|---:|"]
    table += [f"| {k} | {c * 1e3:.1f} | {w:.1f} |" for k, c, w in rows]
    text = "\n".join([f"{measured(load0)} {a.samples} variants x {a.rounds} rounds.", "", *table, "",
                      f"Dask / local CPU: **{ratio:.2f}x** (target at most 1.15x)."])
    print(text)
    if not a.no_write:
        write_section("dask", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

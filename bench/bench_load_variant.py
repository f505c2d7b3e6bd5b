"""The cost of loading one variant of a sweep (``load_variant``: the scenario of one variant, what a
batch child does before each variant it runs), per variant, at studies of several sizes.

Run ``python -m bench load_variant [--sizes 200 1000 10000] [--per 60] [--no-write]``; prints a
table and rewrites its section of ``bench/RESULTS.md`` (between ``<!-- load_variant:start -->`` and
``<!-- load_variant:end -->``) unless ``--no-write``.  The study: the Monte Carlo study of
``bench/bench_montecarlo.py`` (the default scenario, four plant parameters drawn) with ``samples: N``.
Measured in this process, CPU: the first variant loaded (the design drawn; a batch child pays it once),
then ``--per`` variants spread over the study (the cost every further variant of that child pays),
the mean per variant.  Without a cost that grows with ``N`` the per-variant column stays flat.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.bench_montecarlo import study_file  # noqa: E402
from bench.common import cpu_model, git_head, write_section  # noqa: E402
from orchestration.scenario.variants import load_variant  # noqa: E402


def measure(path, n, per):
    """CPU [s] of the first variant loaded and the mean CPU [s] per further variant."""
    c0 = time.process_time()
    load_variant(path, n - 1)
    first = time.process_time() - c0
    indices = [round(k * (n - 1) / max(per - 1, 1)) for k in range(per)]
    c0 = time.process_time()
    for i in indices:
        load_variant(path, i)
    return first, (time.process_time() - c0) / len(indices)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[200, 1000, 10000])
    ap.add_argument("--per", type=int, default=60, help="variants timed per size")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.sizes:
            work = Path(tmp) / str(n)
            work.mkdir()
            first, per = measure(study_file(work, n), n, args.per)
            rows.append((n, first, per))
    load1 = os.getloadavg()[0]
    lines = [f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {cpu_model()}, "
             f"{platform.python_version()}, commit {git_head(ROOT)}, load {load0:.2f} -> {load1:.2f}", "",
             "| variants N | first variant (design drawn) [ms CPU] | per further variant [ms CPU] |",
             "|---:|---:|---:|"]
    lines += [f"| {n} | {1e3 * first:.2f} | {1e3 * per:.3f} |" for n, first, per in rows]
    text = "## load_variant: the cost of one variant's scenario\n\n" + "\n".join(lines) + "\n\n" + (
        "`python -m bench load_variant`: the Monte Carlo study of bench_montecarlo.py with N "
        "samples; CPU in this process, the mean over variants spread over the study.")
    print(text)
    if not args.no_write:
        write_section("load_variant", text)


if __name__ == "__main__":
    main()

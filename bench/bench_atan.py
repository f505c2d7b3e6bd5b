"""The arctan curve's own atan against libm's, in C and in Python.

C: ``fmu/native/core/sm_atan.c`` and the host libm's ``atan`` in one small harness built here with the
host's cc (``-std=c99 -O2 -ffp-contract=off``, as the FMUs), two loops per function, best of
``--rounds`` alternating rounds of CPU time:

* latency: a dependent chain ``x = 0.5 + 1.4 atan(x)`` (each call waits for the previous one, as the
  Newton iterates of the curve solve do; the chain settles near x = 2.0, the curve's working range),
  the same chain without the call subtracted;
* throughput: independent calls over arguments spread on [0.1, 4.1).

Python: ``satmotor.machine.atan.atan`` against ``math.atan`` (timeit, one argument in the table's
range), and ``ArctanCurve.solve`` per call on a spread of equations.

Run ``python -m bench atan``; it prints a table and rewrites its section of ``bench/RESULTS.md``
(``--no-write``: leave it).
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import timeit
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import measured, write_section  # noqa: E402
from orchestration.packaging.native import atan_tables  # noqa: E402
from satmotor.machine.atan import atan  # noqa: E402
from satmotor.machine.magnetics import ArctanCurve  # noqa: E402

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "sm_atan.h"

static double cpu(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef double (*fn)(double);
static double latency(fn f, int n)
{
    volatile double sink;
    double x = 1.3, t0 = cpu();
    for (int i = 0; i < n; ++i) x = 0.5 + 1.4 * f(x);
    sink = x;
    (void)sink;
    return (cpu() - t0) / n * 1e9;
}
static double ident(double x) { return 0.5 * x; }
static double throughput(fn f, int n)
{
    volatile double sink;
    double s = 0.0, t0 = cpu();
    for (int i = 0; i < n; ++i) s += f(0.1 + 4.0 * (double)(i % 1000003) / 1000003.0);
    sink = s;
    (void)sink;
    return (cpu() - t0) / n * 1e9;
}

int main(int argc, char **argv)
{
    int rounds = argc > 1 ? atoi(argv[1]) : 20, n = 2000000;
    fn volatile own = sm_atan, lib = atan, loop = ident; /* volatile: calls through a pointer, no inlining */
    double b[5] = {1e9, 1e9, 1e9, 1e9, 1e9}, v;
    for (int r = 0; r < rounds; ++r) {
        if ((v = latency(lib, n)) < b[0]) b[0] = v;
        if ((v = latency(own, n)) < b[1]) b[1] = v;
        if ((v = latency(loop, n)) < b[2]) b[2] = v;
        if ((v = throughput(lib, n)) < b[3]) b[3] = v;
        if ((v = throughput(own, n)) < b[4]) b[4] = v;
    }
    printf("%.3f %.3f %.3f %.3f %.3f\n", b[0], b[1], b[2], b[3], b[4]);
    return 0;
}
"""


def c_times(rounds):
    core = ROOT / "fmu" / "native" / "core"
    with tempfile.TemporaryDirectory(prefix="bench_atan_") as tmp:
        src, exe = Path(tmp) / "harness.c", Path(tmp) / "harness"
        src.write_text(HARNESS)
        cc = os.environ.get("CC", "cc")
        atan_tables.write(Path(tmp))  # sm_atan_tables.h, generated from satmotor/machine/atan.py
        flags = ["-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror",
                 f"-I{core}", f"-I{tmp}"]
        subprocess.run([cc, *flags, str(src), str(core / "sm_atan.c"), "-o", str(exe), "-lm"], check=True)
        out = subprocess.run([str(exe), str(rounds)], check=True, capture_output=True, text=True).stdout
    return [float(v) for v in out.split()]


def py_time(stmt, glob, number=200_000, repeat=5):
    return min(timeit.repeat(stmt, globals=glob, number=number, repeat=repeat)) / number * 1e6


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--no-write", action="store_true", help="do not rewrite bench/RESULTS.md")
    a = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    lib_lat, own_lat, loop_lat, lib_thr, own_thr = c_times(a.rounds)
    glob = {"atan": atan, "m_atan": math.atan, "x": 1.67}
    py_own, py_lib = py_time("atan(x)", glob), py_time("m_atan(x)", glob)
    curve = ArctanCurve()
    eqs = [(0.05 * (k % 7), 0.2 + 0.9 * (k % 97) / 97) for k in range(20000)]

    def solves():
        for p, q in eqs:
            curve.solve(p, q)
    solve_us = min(timeit.repeat(solves, number=1, repeat=3)) / len(eqs) * 1e6
    lines = [f"load average {load0:.2f} -> {os.getloadavg()[0]:.2f}; "
             f"C best of {a.rounds} rounds of 2e6 calls\n",
             "| | own atan | libm atan |",
             "|---|---|---|",
             f"| C, latency (dependent chain, loop's {loop_lat:.2f} ns taken off) [ns] | "
             f"{own_lat - loop_lat:.2f} | {lib_lat - loop_lat:.2f} |",
             f"| C, throughput [ns per call] | {own_thr:.2f} | {lib_thr:.2f} |",
             f"| Python, one call [us] | {py_own:.3f} | {py_lib:.3f} |",
             f"\nArctanCurve.solve (Python, own atan): {solve_us:.2f} us per call"]
    print("\n".join(lines))
    if not a.no_write:
        title = "## The curve's own atan against libm's (`python -m bench atan`)"
        write_section("atan", "\n".join([title, "", measured(load0) + f" C: best of {a.rounds} rounds.", "",
                                          *lines[1:]]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

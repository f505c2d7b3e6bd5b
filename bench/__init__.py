"""The benchmarks: one runner (``python -m bench NAME...``), every ``bench/bench_NAME.py`` a benchmark.

A benchmark is a module ``bench_NAME`` of this package with ``main(argv)`` (argv: the options after
the names, e.g. ``--rounds 1``) that prints its table and, unless told ``--no-write``, writes its
section of ``RESULTS.md`` through ``bench.common.write_section``.  Adding one is adding that file.
"""

from __future__ import annotations

from pathlib import Path

PREFIX = "bench_"


def names():
    """Every benchmark's name (``bench_NAME.py`` -> ``NAME``), sorted."""
    return sorted(p.stem[len(PREFIX):] for p in Path(__file__).parent.glob(f"{PREFIX}*.py"))

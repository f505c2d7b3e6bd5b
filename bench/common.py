"""What every benchmark shares: the header (date, commit, machine, Python, load) and RESULTS.md.

``header()`` is the one place that says where and when a measurement ran; ``python -m bench`` prints
it before each benchmark and the load average again after it.  ``write_section(name, text)`` puts a
benchmark's table between ``<!-- name:start -->`` and ``<!-- name:end -->`` of ``bench/RESULTS.md``
(``RESULTS`` below; the runner's ``--results PATH`` points it elsewhere), so the file is the last run of
each benchmark plus its hand-written header.
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).with_name("RESULTS.md")


def interpreter(root):
    """The checkout ``root``'s own ``.venv`` interpreter, else this one (``--compare DIR``)."""
    venv = Path(root) / ".venv" / "bin" / "python"
    return str(venv) if venv.exists() else sys.executable


def git_head(root=ROOT):
    """The short commit of the checkout ``root`` ("?" outside git)."""
    r = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True)
    return r.stdout.strip() or "?"


def cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def load():
    """The 1-, 5- and 15-minute load averages as text."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def header(name):
    """The lines printed before benchmark ``name``: date, commit, machine, Python, load."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"== bench {name}: {now}, commit {git_head()}, {platform.machine()} {cpu_model()} "
            f"({os.cpu_count()} CPUs), Python {platform.python_version()}\n"
            f"   load average before: {load()}")


def write_section(name, text):
    """Put ``text`` between ``<!-- name:start -->`` and ``<!-- name:end -->`` in ``RESULTS``.

    Each benchmark owns one such block: an existing block is replaced in place, a missing one is
    appended, and the rest of the file is kept.
    """
    path = RESULTS
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    block = f"{start}\n{text.strip()}\n{end}"
    old = path.read_text(encoding="utf-8") if path.exists() else "# Benchmarks\n"
    i, j = old.find(start), old.find(end)
    if 0 <= i < j:
        new = old[:i] + block + old[j + len(end):]
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    path.write_text(new, encoding="utf-8")
    print(f"wrote section '{name}' of {path}")


def measured(load0):
    """The line a section starts with: date, commit, Python, CPU, load average ``load0`` -> now."""
    return (f"Measured {datetime.date.today().isoformat()} at `{git_head()}`, "
            f"Python {platform.python_version()}, "
            f"CPU: {cpu_model()} ({os.cpu_count()} cores, shared), load average {load0:.2f} -> "
            f"{os.getloadavg()[0]:.2f}.")

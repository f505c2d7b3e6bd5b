"""``python -m bench NAME... [OPTIONS]``: run the named benchmarks (``all``: every one), each after the
shared header (date, commit, machine, Python, load average) and with the load average after it.

OPTIONS (everything from the first ``-`` on, except the runner's own below) go to each benchmark's
``main``; ``python -m bench NAME --help`` shows a benchmark's.  The runner's own options:
``--list`` (the names and each one's first docstring line) and ``--results PATH`` (write the sections
to PATH instead of ``bench/RESULTS.md``).  Exit status: 2 for an unknown name or no name, else the
first nonzero status of a benchmark.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

from bench import PREFIX, common, names


def summary(name):
    """The first line of benchmark ``name``'s docstring, read without importing it."""
    import ast

    path = Path(__file__).with_name(f"{PREFIX}{name}.py")
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    first = " ".join(doc.strip().split("\n\n")[0].split())
    return first if len(first) <= 100 else first[:97] + "..."


def split(argv):
    """(names, the runner's options, the benchmarks' options) of the command line ``argv``."""
    picked, own, rest = [], {}, []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--list":
            own["list"] = True
        elif a == "--results" and i + 1 < len(argv):
            own["results"] = argv[i + 1]
            i += 1
        elif a.startswith("--results="):
            own["results"] = a.split("=", 1)[1]
        elif rest or a.startswith("-"):
            rest.append(a)
        else:
            picked.append(a)
        i += 1
    return picked, own, rest


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    known = names()
    if argv in (["-h"], ["--help"]):
        print(__doc__.strip())
        return 0
    picked, own, rest = split(argv)
    if own.get("list"):
        width = max(map(len, known))
        for n in known:
            print(f"{n:<{width}}  {summary(n)}")
        return 0
    if not picked:
        print("usage: python -m bench NAME... [OPTIONS] | all | --list | --help", file=sys.stderr)
        return 2
    if picked == ["all"]:
        picked = known
    unknown = [n for n in picked if n not in known]
    if unknown:
        print(f"python -m bench: unknown benchmark {', '.join(map(repr, unknown))}; "
              f"known: {', '.join(known)} (bench/{PREFIX}NAME.py)", file=sys.stderr)
        return 2
    if "results" in own:
        common.RESULTS = Path(own["results"]).resolve()
    status = 0
    for n in picked:
        print(common.header(n), flush=True)
        module = importlib.import_module(f"bench.{PREFIX}{n}")
        try:
            code = module.main(list(rest))
        except SystemExit as e:
            code = e.code
        if isinstance(code, str):
            print(code, file=sys.stderr)
        code = code if isinstance(code, int) else (0 if code is None else 1)
        print(f"   load average after: {common.load()} (bench {n}: exit {code})\n", flush=True)
        status = status or code
    return status


if __name__ == "__main__":
    sys.exit(main())

"""A scenario file's sweep read and checked: the file's own scenario and every variant of its
``sweep:`` section (:mod:`orchestration.scenario.sweep` expands it) checked as a scenario of its own
by the loader (:mod:`orchestration.scenario.load`).  ``validate`` and ``batch`` check every variant
before anything runs; the run of one variant (``run FILE --sweep-variant I``) builds only its own."""

from __future__ import annotations

from orchestration.scenario.load import ScenarioError, _check, _read
from orchestration.scenario.problems import Problem
from orchestration.scenario.sweep import expand

__all__ = ["check_sweep", "load_sweep", "load_variant"]


def check_sweep(data, file, variables, base_problems):
    """``(Sweep or None, [(variant, Scenario)], problems)`` of the ``sweep:`` section of ``data``:
    every variant checked as a scenario of its own; a variant's problem names the variant and its
    values (a problem the base scenario has already is not repeated per variant)."""
    sweep, problems = expand(data, file)
    if sweep is None:
        return None, [], problems
    out = []
    for v in sweep.variants:
        sc, probs = _check(v.data, file, variables)
        said = ", ".join(f"{p} = {x!r}" for p, x in v.values)
        problems += [Problem(p.file, p.field, p.value, f"{p.message} [variant {v.name}: {said}]")
                     for p in probs if p not in base_problems]
        if sc is not None:
            out.append((v, sc))
    return sweep, out, problems


def load_sweep(path, variables=None):
    """``(base Scenario, Sweep or None, [(Variant, Scenario)])`` of the scenario file ``path``:
    the file's own scenario, and its sweep's variants, every one checked; raises
    :class:`ScenarioError` listing every problem of the file and of its variants."""
    data, problems = _read(path)
    if not problems:
        sc, problems = _check(data, str(path), variables)
        sweep, variants, more = check_sweep(data, str(path), variables, problems)
        problems = problems + more
    if problems:
        raise ScenarioError(problems, str(path))
    return sc, sweep, variants


def load_variant(path, index, variables=None):
    """The :class:`Scenario` of variant ``index`` of the sweep of the scenario file ``path`` (only
    that variant checked: the batch that runs it has checked them all); raises
    :class:`ScenarioError` (a file without a sweep, an index out of range: one problem)."""
    data, problems = _read(path)
    if not problems:
        sweep, problems = expand(data, str(path), only=index)
        if not problems and (sweep is None or not 0 <= index < len(sweep.variants)):
            count = len(sweep.variants) if sweep else 0
            problems = [Problem(str(path), "sweep", index, f"no variant {index}: the file has {count}")]
        if not problems:
            sc, problems = _check(sweep.variants[index].data, str(path), variables)
    if problems:
        raise ScenarioError(problems, str(path))
    return sc

"""A scenario file's sweep read and checked: the file's own scenario and every variant of its
``sweep:`` section (:mod:`orchestration.scenario.sweep` expands it) checked as a scenario of its own
by the loader (:mod:`orchestration.scenario.load`).  ``validate`` and ``batch`` check every variant
before anything runs; the run of one variant (``run FILE --sweep-variant I``) builds only its own."""

from __future__ import annotations

import functools
from pathlib import Path

import yaml

from orchestration.scenario.load import ScenarioError, _check, _parse, _read
from orchestration.scenario.problems import Problem
from orchestration.scenario.sweep import expand
from orchestration.scenario.sweep import plan as plan_sweep

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
    :class:`ScenarioError` (a file without a sweep, an index out of range: one problem).

    The file is read every time; its parsed YAML and its sweep's design are kept per process for
    the last few texts read (:func:`_planned`): the variants after the first of a batch child cost
    the same whatever the size of the study."""
    file = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        text = None
    if text is None:
        data, problems, plan = None, _read(path)[1], None
    else:
        data, problems, plan = _planned(file, text)
    if not problems:
        if plan is None or not 0 <= index < len(plan):
            count = len(plan) if plan is not None else 0
            problems = [Problem(file, "sweep", index, f"no variant {index}: the file has {count}")]
        else:
            sc, problems = _check(plan.variant(index).data, file, variables)
    if problems:
        raise ScenarioError(problems, file)
    return sc


@functools.lru_cache(maxsize=4)
def _planned(file, text):
    """``(data, problems, Plan or None)`` of the scenario file ``file`` whose text is ``text``: the
    YAML parsed and the sweep's design drawn once per text (the callers copy what they change)."""
    try:
        data, problems = _parse(text, file)
    except yaml.YAMLError:
        data, problems = _read(file)  # says the syntax problem as the loader does
    if problems:
        return data, problems, None
    plan, problems = plan_sweep(data, file)
    return data, problems, plan

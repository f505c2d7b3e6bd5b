"""The validator of scenario files: every problem of a file, and of each variant of its ``sweep:``
section, at once (:mod:`orchestration.scenario.load` reads one scenario,
:mod:`orchestration.scenario.variants` the variants of a sweep; this module uses both, so neither
imports the other's caller)."""

from __future__ import annotations

from orchestration.scenario.load import _check, _read
from orchestration.scenario.problems import Problem
from orchestration.scenario.sweep import expand
from orchestration.scenario.variants import check_sweep

__all__ = ["check_scenario_file", "validate_scenario_file", "variant_count", "scenario_name"]


def check_scenario_file(path, variables=None):
    """``(problems, notes)`` of the scenario file ``path``: every :class:`Problem` (empty: valid)
    and, for a valid file, its :class:`Note` lines; with a ``sweep:`` section, every variant's
    problems too.  Never raises.

    ``variables``: ``{"plant": {name: (causality, type)}, "controller": {...}}`` of the FMUs
    (e.g. from fmpy's model descriptions); None: :func:`interface_variables`.
    """
    try:
        data, problems = _read(path)
        if problems:
            return problems, []
        sc, problems = _check(data, str(path), variables)
        if isinstance(data, dict) and "sweep" in data:  # every variant checked too
            problems = problems + check_sweep(data, str(path), variables, problems)[2]
        return problems, list(sc.notes) if sc is not None and not problems else []
    except Exception as exc:  # noqa: BLE001 - a validator reports, it does not crash
        return [Problem(str(path), "(internal)", None, f"validation failed: {exc!r}")], []


def validate_scenario_file(path, variables=None):
    """Every problem of the scenario file ``path`` (empty list: valid).  Never raises.
    ``variables`` as for :func:`check_scenario_file`."""
    return check_scenario_file(path, variables)[0]


def variant_count(path):
    """How many variants the ``sweep:`` section of the scenario file ``path`` expands to (None: no
    sweep, or a file that cannot be read or expanded).  Never raises."""
    try:
        data, problems = _read(path)
        if problems or not isinstance(data, dict) or "sweep" not in data:
            return None
        sweep = expand(data, str(path))[0]
        return None if sweep is None else len(sweep.variants)
    except Exception:  # noqa: BLE001 - a count for a status line, never a crash
        return None


def scenario_name(path):
    """The ``name`` of the scenario file ``path`` (its results directory), or None.  Never raises."""
    try:
        data, problems = _read(path)
        return data.get("name") if not problems and isinstance(data, dict) else None
    except Exception:  # noqa: BLE001 - a name for a check, never a crash
        return None

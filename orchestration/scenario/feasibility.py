"""What a scenario asks of the physics, checked before any FMU runs.

The ranges live once, in :mod:`satmotor` (its dataclasses raise :class:`satmotor.errors.ParameterError`
naming the field and the value): here the plain-Python plant and controller units are built from
the scenario's overrides, exactly as the FMUs build them at initialization, and every refusal
becomes a :class:`~orchestration.scenario.profiles.Problem` (file, field, value).  Then the flux set-point
profile is checked against what the controller can magnetize, and the size of the recording
against :data:`MAX_RECORDED_VALUES`.
"""

from __future__ import annotations

from orchestration.scenario.problems import Problem

#: Largest number of recorded values (rows x columns) a run may produce.  The recorder streams
#: its rows to disk in chunks, so the run itself holds one chunk; the bound keeps the files and
#: their post-processing (metrics, figure: the columns read back, 8 bytes a value) finite:
#: 1e8 values are about 0.8 GB in memory and 2 GB of CSV.
MAX_RECORDED_VALUES = 100_000_000


def _build(unit_class, unit, overrides, extra, file, problems):
    """Build ``unit_class`` from ``extra`` + ``overrides``; on each refusal, record it and retry
    without the refused override, so that every bad override is reported.  The unit, or None."""
    from satmotor.errors import ParameterError

    values = dict(overrides)
    for _ in range(len(values) + 1):
        try:
            return unit_class({**extra, **values})
        except ParameterError as exc:
            reason = f"{exc.reason} (in {exc.source})" if exc.source else exc.reason
            name = exc.field.split(".")[0]
            name = name if name in values else exc.field
            problems.append(Problem(file, f"{unit}.{name}", values.get(name, exc.value), reason))
            if name not in values:
                return None  # a default or a derived value is refused: nothing more to learn
            del values[name]
        except Exception as exc:  # noqa: BLE001 - a checker reports, it does not crash
            problems.append(Problem(file, unit, dict(overrides), f"the {unit} cannot be built: {exc!r}"))
            return None
    return None


def physics_problems(sc):
    """Every problem the physics package finds with scenario ``sc`` (empty list: none)."""
    from satmotor.interface import ControllerUnit, PlantUnit

    file = str(sc.path)
    problems = []
    _build(PlantUnit, "plant", sc.plant, {}, file, problems)
    ctrl = _build(ControllerUnit, "controller", sc.controller, {"Ts": sc.Ts}, file, problems)
    psi = sc.profiles["psi_ref"]
    lo, hi = psi.bounds(0.0, sc.stop_time)
    if not lo > 0:
        problems.append(Problem(file, "profiles.psi_ref", lo, f"the flux set-point must stay > 0 over "
                                f"[0, stop_time = {sc.stop_time!r}] s (its lowest value is {lo!r} Wb)"))
    elif ctrl is not None:
        from satmotor.errors import ParameterError

        try:
            ctrl.drive.magnetizing_current(hi)
        except ParameterError as exc:
            problems.append(Problem(file, "profiles.psi_ref", hi, f"unreachable: the highest set-point "
                                    f"{exc.reason} (raise controller.I_max or lower the set-point)"))
    rows, cols = recorded_size(sc)
    if rows * cols > MAX_RECORDED_VALUES:
        problems.append(Problem(file, "stop_time", sc.stop_time, (
            f"would record {rows:.4g} rows x {cols} columns = {rows * cols:.3g} values (every "
            f"record.interval = {sc.record.interval!r} s); the limit is {MAX_RECORDED_VALUES:.0e} values: "
            "shorten stop_time, raise record.interval or list fewer record.outputs")))
    return problems


def recorded_size(sc):
    """(rows, columns) of the recording of ``sc``: the columns the results writer keeps
    (:func:`orchestration.results.writer.recorded_selection`: time, the profiles, the measured signals, the
    recorded outputs and the ones the metrics and the figure need)."""
    from orchestration.results.writer import recorded_selection
    from orchestration.run.result import recorded_columns
    from satmotor.interface import CONTROLLER_OUTPUTS, PLANT_OUTPUTS

    measured = sc.measurements.columns if sc.measurements is not None else ()
    columns = recorded_columns([v.name for v in PLANT_OUTPUTS], [v.name for v in CONTROLLER_OUTPUTS],
                               sorted(sc.profiles), measured)
    rows = int(sc.stop_time / sc.record.interval + 1e-9) + 1
    return rows, len(recorded_selection(sc, columns))

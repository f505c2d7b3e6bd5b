"""What a scenario asks of the physics, checked before any FMU runs.

The ranges live once, in :mod:`satmotor` (its dataclasses raise :class:`satmotor.errors.ParameterError`
naming the field and the value): here the plain-Python plant and controller units are built from
the scenario's overrides, exactly as the FMUs build them at initialization, and every refusal
becomes a :class:`~orchestration.scenario.profiles.Problem` (file, field, value).  Then the flux set-point
profile is checked against what the controller can magnetize, and the size of the recording
against :data:`MAX_RECORDED_VALUES`.  A load whose peak exceeds the torque the controller's
current limit allows (:func:`load_torque_limit`) is a note, not a problem: the run is allowed (a
current-limited drive is a legitimate study), and its steady-state status then says the speed is
not held.  The checks run on whatever part of a scenario is well formed (a missing stop time, a
profile with problems: the checks that need it are skipped), so that a file's schema problems and
its bad values are found in one pass.
"""

from __future__ import annotations

from orchestration.scenario.plausibility import plausibility_notes
from orchestration.scenario.problems import Note, Problem

#: Largest number of recorded values (rows x columns) a run may keep (:func:`kept_size`: what its
#: record level writes, not what it computes: level ``metrics`` keeps none).  The recorder streams
#: its rows to disk in chunks, so the run itself holds one chunk; the bound keeps the files and
#: their post-processing (metrics, figure: the columns read back, 8 bytes a value) finite:
#: 1e8 values are about 0.8 GB in memory and 2 GB of CSV.
MAX_RECORDED_VALUES = 100_000_000


def _build(unit_class, unit, overrides, extra, file, problems, fields=None):
    """Build ``unit_class`` from ``extra`` + ``overrides``; on each refusal, record it and retry
    without the refused override, so that every bad override is reported.  ``fields``: the field
    path of each override (``motor.R_r`` for a value of the ``motor:`` section; default
    ``unit.NAME``).  The unit, or None."""
    from satmotor.errors import ParameterError

    values = dict(overrides)
    for _ in range(len(values) + 1):
        try:
            return unit_class({**extra, **values})
        except ParameterError as exc:
            reason = f"{exc.reason} (in {exc.source})" if exc.source else exc.reason
            name = exc.field.split(".")[0]
            name = name if name in values else exc.field
            where = (fields or {}).get(name, f"{unit}.{name}")
            problem = Problem(file, where, values.get(name, exc.value), reason)
            if problem not in problems:  # a bad motor: value refused by both units: said once
                problems.append(problem)
            if name not in values:
                return None  # a default or a derived value is refused: nothing more to learn
            del values[name]
        except Exception as exc:  # noqa: BLE001 - a checker reports, it does not crash
            problems.append(Problem(file, unit, dict(overrides), f"the {unit} cannot be built: {exc!r}"))
            return None
    return None


def physics_problems(sc):
    """Every problem the physics package finds with scenario ``sc`` (empty list: none)."""
    return physics_check(sc)[0]


def physics_check(sc, fields=None):
    """``(problems, notes)`` the physics finds with scenario ``sc``: the problems refuse it, the
    notes (:class:`orchestration.scenario.problems.Note`) are said.  ``fields``: ``{"plant": {name: field
    path}, "controller": ...}`` of the overrides (default ``unit.NAME``).  ``sc.stop_time`` None,
    ``sc.record`` None or a profile missing: the checks that need it are skipped."""
    from satmotor.interface import ControllerUnit, PlantUnit

    file = str(sc.path)
    fields = fields or {}
    problems, notes = [], []
    plant = _build(PlantUnit, "plant", sc.plant, {}, file, problems, fields.get("plant"))
    ctrl = _build(ControllerUnit, "controller", sc.controller, {"Ts": sc.Ts}, file, problems,
                  fields.get("controller"))
    notes.extend(plausibility_notes(sc, plant, ctrl, file, fields))  # inputs far beyond the motor: said
    psi = sc.profiles.get("psi_ref")
    if psi is None or sc.stop_time is None:
        return problems, notes
    lo, hi = psi.bounds(0.0, sc.stop_time)
    reachable = False
    if not lo > 0:
        problems.append(Problem(file, "profiles.psi_ref", lo, f"the flux set-point must stay > 0 over "
                                f"[0, stop_time = {sc.stop_time!r}] s (its lowest value is {lo!r} Wb)"))
    elif ctrl is not None:
        from satmotor.errors import ParameterError

        try:
            ctrl.drive.magnetizing_current(hi)
            reachable = True
        except ParameterError as exc:
            problems.append(Problem(file, "profiles.psi_ref", hi, f"unreachable: the highest set-point "
                                    f"{exc.reason} (raise controller.I_max or lower the set-point)"))
    if sc.record is not None:
        rows, cols = kept_size(sc)
        if rows * cols > MAX_RECORDED_VALUES:
            decimated = sc.record.level == "decimated"
            every = f", one row of record.every = {sc.record.every} kept" if decimated else ""
            problems.append(Problem(file, "stop_time", sc.stop_time, (
                f"would record {rows:.4g} rows x {cols} columns = {rows * cols:.3g} values (every "
                f"record.interval = {sc.record.interval!r} s{every}); the limit is {MAX_RECORDED_VALUES:.0e} "
                "values: shorten stop_time, raise record.interval or record.every, list fewer "
                "record.outputs, or record: metrics")))
    load = sc.profiles.get("T_load")
    if reachable and plant is not None and load is not None:

        T_lo, T_hi = load.bounds(0.0, sc.stop_time)
        peak = max(abs(T_lo), abs(T_hi))
        I_max = ctrl.drive.dcfg.I_max
        T_max, psi_at = load_torque_limit(plant.params, I_max, lo, hi)
        if peak > T_max:  # says more than the plausibility note of the same load (if any): instead of it
            notes = [n for n in notes if n.field != "profiles.T_load"]
            notes.append(Note(file, "profiles.T_load", peak, (
                f"the load's peak |T_load| = {peak:.4g} N m exceeds {T_max:.4g} N m, the most torque the "
                f"plant gives at |i_s| = controller I_max = {I_max:.4g} A and |psi_r| = {psi_at:.4g} Wb "
                "(psi_ref): the speed cannot hold its set-point there (raise controller.I_max or lower "
                "the load)")))
    return problems, notes


#: flux set-points at which :func:`load_torque_limit` evaluates the limit when psi_ref varies
FLUX_POINTS = 9


def load_torque_limit(params, I_max, psi_lo, psi_hi):
    """``(T_max, psi)``: the largest steady torque [N m] the motor ``params`` gives with ``|i_s| <=
    I_max`` [A] at any flux set-point in ``[psi_lo, psi_hi]`` [Wb] (evaluated at :data:`FLUX_POINTS`
    points; :func:`satmotor.limits.torque_limit`), and the flux where it is reached.  A load beyond
    it cannot be held at any flux set-point the scenario gives."""
    from satmotor.errors import ParameterError
    from satmotor.limits import torque_limit

    n = 1 if psi_hi == psi_lo else FLUX_POINTS
    best = (0.0, psi_hi)
    for i in range(n):
        psi = psi_lo + (psi_hi - psi_lo) * i / max(n - 1, 1)
        try:
            T = torque_limit(params, psi, I_max).T_max
        except ParameterError:
            continue
        best = max(best, (T, psi))
    return best


def recorded_size(sc):
    """(rows, columns) of the recording of ``sc``: the columns the results writer keeps
    (:func:`orchestration.scenario.recording.recorded_selection`: time, the profiles, the measured
    signals, the recorded outputs and the ones the metrics and the figure need)."""
    from orchestration.scenario.recording import recorded_columns, recorded_selection
    from satmotor.interface import CONTROLLER_OUTPUTS, PLANT_OUTPUTS

    measured = sc.measurements.columns if sc.measurements is not None else ()
    columns = recorded_columns([v.name for v in PLANT_OUTPUTS], [v.name for v in CONTROLLER_OUTPUTS],
                               sorted(sc.profiles), measured)
    rows = int(sc.stop_time / sc.record.interval + 1e-9) + 1
    return rows, len(recorded_selection(sc, columns))


def kept_size(sc):
    """(rows, columns) the record level of ``sc`` keeps of :func:`recorded_size`: every row
    (``full``), one of ``record.every`` from the first (``decimated``), none (``metrics``: the rows
    are folded into the metrics chunk by chunk and dropped,
    :class:`orchestration.results.recorder.MetricsOnly`)."""
    rows, cols = recorded_size(sc)
    level = sc.record.level
    if level == "metrics":
        return 0, cols
    if level == "decimated":
        return -(-rows // max(1, sc.record.every)), cols
    return rows, cols

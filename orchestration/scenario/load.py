"""Scenario files (YAML): what the co-simulation master runs, checked before anything is run.

Top-level keys (SI units; see ``scenarios/ramp_rated_load.yaml`` for a full example):

``name`` (required, ``[A-Za-z0-9_.-]+``), ``description``, ``stop_time`` [s] (required, a multiple of
``step``), ``step`` [s] (plant communication step, default 1e-4), ``controller_every`` (plant steps
per controller sample, default 1; the controller's ``Ts = step * controller_every``),
``algorithm`` (``gauss-seidel`` default, or ``jacobi``), ``motor`` (motor parameters given to
both units: the names of :data:`satmotor.interface.MOTOR_PARAMETERS`, which the plant and the
controller's model share, and the plant-only machine data :data:`satmotor.interface.PLANT_MOTOR_NAMES`
(core loss ``R_fe``, the thermal constants: given to the plant alone), or ``preset: NAME`` of a motor of
:mod:`satmotor.machine.library` with overrides beside it, :mod:`orchestration.scenario.presets`),
``plant`` and ``controller``
(parameter overrides by FMI variable name, over ``motor``: only the deliberate differences),
``mismatch`` (``true``: the plant and the controller are meant to get different motor parameters;
default false), ``profiles``
(``omega_ref`` [rad/s], default 0; ``psi_ref`` [Wb], required; ``T_load`` [N m], default 0; see
:mod:`orchestration.scenario.profiles`), ``record``
(``level``: ``full`` (default), ``decimated`` (every ``every``-th recorded row on disk, default 10)
or ``metrics`` (no time series on disk; ``record: metrics`` alone says the same); ``interval`` [s],
a multiple of ``step``, default ``step``; ``outputs``: ``plant.NAME`` /
``controller.NAME``, default all), ``sweep`` (variants of the scenario:
:mod:`orchestration.scenario.sweep`, :mod:`orchestration.scenario.variants`),
``acceptance`` (bounds checked after the run: ``ss_speed``,
``ss_flux`` relative steady-state errors over ``ss_window: [t_from, t_to]`` [s],
``overshoot_speed`` relative, ``peak_current``, ``peak_current_run`` [A], ``final_overshoot_speed``
[rad/s], ``holds_setpoints: true``: a run that does not hold its set-points misses its acceptance,
:func:`orchestration.results.writer.setpoint_status`), ``measurements``
(noise and quantization the master applies to the plant outputs it passes to the controller:
``seed`` (integer >= 0, default 0), ``noise: {NAME: std}`` (Gaussian standard deviation >= 0) and
``quantization: {NAME: step}`` (step > 0), each in the signal's unit, NAME one of
:data:`orchestration.scenario.system.MEASUREMENTS`; see :mod:`orchestration.run.measurement_noise`).

In the same pass, :func:`orchestration.scenario.feasibility.physics_check` builds the plain-Python units from
the values that passed the schema (the ranges live in :mod:`satmotor`), checks that the flux
set-points are reachable and that the recording stays within its bound: a file's schema problems
and its bad values are reported together.

Notes (:class:`Note`: said, never refused): a motor parameter that ends up different in the plant
and the controller (one line per parameter, unless ``mismatch: true``), ``mismatch: true`` with no
difference, and a load whose peak exceeds the torque the controller's current limit allows
(:func:`orchestration.scenario.feasibility.physics_check`).

:func:`orchestration.scenario.validate.validate_scenario_file` returns every problem and never
raises (``check_scenario_file`` also the notes); :func:`load_scenario` raises one
:class:`ScenarioError` listing all of them, and the scenario it returns carries its notes
(``Scenario.notes``).  Numbers are ints or floats; YAML 1.1
reads ``1e-4`` (no dot) as a string, which is reported with the spelling to use (``1.0e-4``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from types import MappingProxyType

import yaml

from orchestration.scenario.feasibility import physics_check
from orchestration.scenario.presets import expand as expand_preset
from orchestration.scenario.problems import Checker, Note, Problem
from orchestration.scenario.profiles import Constant, parse_profile
from orchestration.scenario.system import Measurements

__all__ = ["Problem", "Note", "ScenarioError", "Acceptance", "Record", "Scenario", "Measurements",
           "load_scenario",
           "interface_variables", "motor_variables", "ALGORITHMS", "PROFILE_NAMES"]

ALGORITHMS = ("gauss-seidel", "jacobi")
PROFILE_NAMES = ("omega_ref", "psi_ref", "T_load")
UNITS = ("plant", "controller")
TOP_KEYS = ("name", "description", "stop_time", "step", "controller_every", "algorithm", "motor", "plant",
            "controller", "mismatch", "profiles", "record", "acceptance", "measurements", "sweep")
RECORD_LEVELS = ("full", "decimated", "metrics")  # what a run keeps: orchestration.results.recorder
ACCEPTANCE_KEYS = ("ss_speed", "ss_flux", "ss_window", "overshoot_speed", "peak_current", "peak_current_run",
                   "final_overshoot_speed", "peak_v_dc", "holds_setpoints")
_NAME = re.compile(r"[A-Za-z0-9_.-]+")
_REL = 1e-9  # relative tolerance of "a multiple of step"
#: libyaml's safe loader when PyYAML has it (the same documents, ten times faster: a sweep's variants
#: each read their file), else the pure-Python one
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
DECIMATE_DEFAULT = 10  # record.every of level decimated when the file does not say


class ScenarioError(ValueError):
    """A scenario file with problems; ``.problems`` lists every :class:`Problem`."""

    def __init__(self, problems, file=None):
        self.problems = list(problems)
        where = file or (self.problems[0].file if self.problems else "scenario")
        lines = "\n".join(f"  {p}" for p in self.problems)
        super().__init__(f"{where}: {len(self.problems)} problem(s):\n{lines}")


@dataclass(frozen=True)
class Acceptance:
    """Bounds checked after a run; None: not checked."""

    ss_speed: float | None = None  # [1] largest |omega_m - omega_ref| / |final omega_ref| in the window
    ss_flux: float | None = None  # [1] largest ||psi_r| - psi_ref| / final psi_ref in the window
    ss_window: tuple[float, float] | None = None  # [s] (t_from, t_to); None: the last 10 % of the run
    overshoot_speed: float | None = None  # [1] relative to the total speed change
    peak_current: float | None = None  # [A] largest |i_s|
    peak_current_run: float | None = None  # [A] largest |i_s| once the law runs (the current limit)
    final_overshoot_speed: float | None = None  # [rad/s] beyond the final set-point after its last change
    peak_v_dc: float | None = None  # [V] largest DC-link voltage (plant dc_link: capacitor)
    holds_setpoints: bool = False  # True: a run that does not hold its set-points misses its acceptance


@dataclass(frozen=True)
class Record:
    interval: float  # [s] a multiple of the step
    outputs: tuple[str, ...] = ()  # "plant.NAME" / "controller.NAME"; empty: all outputs of both
    level: str = "full"  # full: every row on disk; decimated: every `every`-th; metrics: none on disk
    every: int = 1  # decimated: one row of `every` recorded rows goes to disk


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    path: Path | None  # the scenario file
    stop_time: float  # [s]
    step: float = 1e-4  # [s] plant communication step
    controller_every: int = 1  # plant steps per controller sample
    algorithm: str = "gauss-seidel"
    plant: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))  # {FMI name: value}
    controller: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))
    profiles: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))  # name -> profile
    record: Record | None = None  # None: every step, all outputs
    acceptance: Acceptance | None = None
    measurements: Measurements | None = None  # None: the controller gets the clean plant outputs
    # the ``motor:`` section as written (plant and controller above already hold it, merged)
    motor: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))
    mismatch: bool = False  # the scenario says a plant/controller motor mismatch is intended
    notes: tuple = ()  # Note: what is allowed but said (mismatch, load beyond the torque limit)
    preset: str = ""  # ``motor: {preset: NAME}``: the library motor the scenario starts from ("": none)

    @property
    def Ts(self):
        """Controller sample period [s] (the controller FMU's ``Ts`` is set to it)."""
        return self.step * self.controller_every

    def __reduce__(self):  # a MappingProxyType does not pickle: send dicts (process pools, Dask)
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return _unpickle, ({k: dict(v) if isinstance(v, MappingProxyType) else v for k, v in values.items()},)


def _unpickle(values):
    return Scenario(**{k: MappingProxyType(v) if isinstance(v, dict) else v for k, v in values.items()})


def interface_variables():
    """``{"plant": {name: (causality, type)}, "controller": {...}}`` from :mod:`satmotor.interface`,
    the same shape as the master reads from the FMUs' model descriptions."""
    from satmotor import interface as itf

    def table(*groups):
        return {v.name: (v.causality, v.type) for g in groups for v in g}

    return {"plant": table(itf.PLANT_INPUTS, itf.PLANT_OUTPUTS, itf.PLANT_PARAMETERS),
            "controller": table(itf.CONTROLLER_INPUTS, itf.CONTROLLER_OUTPUTS, itf.CONTROLLER_PARAMETERS)}


def motor_variables(variables=None):
    """``{name: (causality, type)}`` of the motor parameters (:data:`satmotor.interface.MOTOR_PARAMETERS`:
    the ones the plant and the controller's model share) that both units of ``variables`` (default
    :func:`interface_variables`) have as parameters."""
    from satmotor.interface import MOTOR_PARAMETERS

    variables = variables if variables is not None else interface_variables()
    plant, ctrl = variables.get("plant", {}), variables.get("controller", {})
    return {v.name: plant[v.name] for v in MOTOR_PARAMETERS
            if plant.get(v.name, ("",))[0] == "parameter" and ctrl.get(v.name, ("",))[0] == "parameter"}


def _choices():
    """Allowed values of String parameters, by (unit, name): the interface tables' ``choices``."""
    from satmotor.interface import CONTROLLER_PARAMETERS, PLANT_PARAMETERS

    return {(unit, v.name): v.choices for unit, table in (("plant", PLANT_PARAMETERS),
                                                           ("controller", CONTROLLER_PARAMETERS))
            for v in table if v.choices}


def _plant_motor_names():
    """The plant-only parameters a ``motor:`` section (and a preset) may hold: the machine's core loss and
    thermal data (:data:`satmotor.interface.PLANT_MOTOR_NAMES`), which the controller's model ignores."""
    from satmotor.interface import PLANT_MOTOR_NAMES

    return PLANT_MOTOR_NAMES


def _multiple(x, step):
    n = round(x / step)
    return n >= 1 and abs(x - n * step) <= _REL * x


def _overrides(chk, raw, unit, variables, base_dir):
    """Check ``plant:`` / ``controller:`` overrides against the unit's variables."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        chk.add(unit, raw, "must be a mapping {parameter name: value}")
        return {}
    table = motor_variables(variables) if unit == "motor" else variables.get(unit, {})
    if unit == "motor":  # the machine's data only the plant models (R_fe, thermal): to the plant alone
        own = _plant_motor_names()
        table = {**table, **{n: t for n, t in variables.get("plant", {}).items() if n in own}}
    out, choices = {}, _choices()
    for name, value in raw.items():
        where = f"{unit}.{name}"
        if unit == "motor" and name not in table:
            owners = [u for u in UNITS if variables.get(u, {}).get(name, ("",))[0] == "parameter"]
            hint = (f"a {owners[0]} parameter only: set it under {owners[0]}:" if len(owners) == 1 else
                    "unknown parameter")
            chk.add(where, value, f"not a motor parameter (those shared by plant and controller: "
                    f"{', '.join(table)}); {hint}")
            continue
        if unit == "controller" and name == "Ts":
            chk.add(where, value, "Ts is set by the master to step * controller_every; "
                    "set step and controller_every instead")
            continue
        if name not in table:
            chk.add(where, value, f"unknown {unit} variable")
            continue
        causality, vtype = table[name]
        if causality != "parameter":
            chk.add(where, value, f"is {'an' if causality[0] in 'aeio' else 'a'} {causality} of the {unit}, "
                    "only parameters can be overridden")
            continue
        if vtype == "Real":
            v = chk.number(value, where)
        elif vtype in ("Integer", "Enumeration"):
            v = chk.integer(value, where)
        elif vtype == "Boolean":
            v = value if isinstance(value, bool) else None
            if v is None:
                chk.add(where, value, "must be true or false")
        elif vtype == "String":
            v = chk.string(value, where)
            allowed = choices.get(("plant" if unit == "motor" else unit, name))
            if v is not None and allowed and v not in allowed:
                chk.add(where, value, f"must be one of {', '.join(allowed)}")
                v = None
            if v and name == "table_file":
                resolved = (base_dir / v).resolve()
                if not resolved.is_file():
                    chk.add(where, value, f"no such file: {resolved}")
                    v = None
                else:
                    v = str(resolved)
        else:
            chk.add(where, value, f"variables of type {vtype} cannot be overridden")
            v = None
        if v is not None:
            out[name] = v
    return out


def _record(chk, raw, step, variables):
    if raw is None:
        return Record(step if step else 1e-4, ())
    if isinstance(raw, str):  # record: metrics -- the level alone
        raw = {"level": raw}
    if not chk.mapping(raw, "record", (), ("level", "every", "interval", "outputs")):
        return None
    level = raw.get("level", "full")
    if level not in RECORD_LEVELS:
        chk.add("record.level", level, f"must be one of {', '.join(RECORD_LEVELS)}")
        level = "full"
    every = 1
    if "every" in raw:
        every = chk.integer(raw["every"], "record.every", low=1) or 1
        if level != "decimated":
            chk.add("record.every", raw["every"], f"applies to level: decimated only (level is {level})")
    elif level == "decimated":
        every = DECIMATE_DEFAULT
    interval = step
    if "interval" in raw:
        interval = chk.number(raw["interval"], "record.interval", low=0.0, strict=True)
        if interval is not None and step and not _multiple(interval, step):
            chk.add("record.interval", raw["interval"], f"must be a multiple of step = {step!r}")
    outputs = raw.get("outputs") or []
    if not isinstance(outputs, list):
        chk.add("record.outputs", outputs, "must be a list of 'plant.NAME' / 'controller.NAME'")
        outputs = []
    for i, name in enumerate(outputs):
        unit, _, var = name.partition(".") if isinstance(name, str) else ("", "", "")
        if unit not in UNITS or variables.get(unit, {}).get(var, ("",))[0] != "output":
            chk.add(f"record.outputs[{i}]", name, "not an output; write 'plant.NAME' or 'controller.NAME' "
                    "with NAME an output of that FMU")
    return Record(interval or step or 1e-4, tuple(o for o in outputs if isinstance(o, str)), level, every)


def _acceptance(chk, raw, stop_time):
    if raw is None:
        return None
    if not chk.mapping(raw, "acceptance", (), ACCEPTANCE_KEYS):
        return None
    vals = {}
    for key in ("ss_speed", "ss_flux", "overshoot_speed", "peak_current", "peak_current_run",
                "final_overshoot_speed", "peak_v_dc"):
        if key in raw:
            vals[key] = chk.number(raw[key], f"acceptance.{key}", low=0.0, strict=True)
    if "holds_setpoints" in raw:
        if isinstance(raw["holds_setpoints"], bool):
            vals["holds_setpoints"] = raw["holds_setpoints"]
        else:
            chk.add("acceptance.holds_setpoints", raw["holds_setpoints"], "must be true or false")
    if "ss_window" in raw:
        w = raw["ss_window"]
        if not (isinstance(w, list) and len(w) == 2):
            chk.add("acceptance.ss_window", w, "must be a pair [t_from, t_to] [s]")
        else:
            a = chk.number(w[0], "acceptance.ss_window[0]", low=0.0)
            b = chk.number(w[1], "acceptance.ss_window[1]", low=0.0)
            if a is not None and b is not None:
                if not a < b:
                    chk.add("acceptance.ss_window", w, "t_from must be < t_to")
                elif stop_time is not None and b > stop_time * (1 + _REL):
                    chk.add("acceptance.ss_window[1]", w[1], f"must be <= stop_time = {stop_time!r}")
                else:
                    vals["ss_window"] = (a, b)
    return Acceptance(**vals)


def _measurements(chk, raw):
    """The ``measurements:`` section: seed, noise and quantization by measured signal."""
    from orchestration.scenario.system import MEASUREMENTS

    if raw is None:
        return None
    if not chk.mapping(raw, "measurements", (), ("seed", "noise", "quantization")):
        return None
    seed = chk.integer(raw.get("seed", 0), "measurements.seed", low=0)
    tables = {}
    for key, strict, what in (("noise", False, "standard deviation"), ("quantization", True, "step")):
        table = raw.get(key)
        if table is None:
            tables[key] = ()
            continue
        if not isinstance(table, dict):
            chk.add(f"measurements.{key}", table, f"must be a mapping {{signal: {what}}}")
            continue
        vals = {}
        for name, value in table.items():
            where = f"measurements.{key}.{name}"
            if name not in MEASUREMENTS:
                chk.add(where, value, f"not a measured signal; allowed: {', '.join(MEASUREMENTS)}")
                continue
            v = chk.number(value, where, low=0.0, strict=strict)
            if v is not None:
                vals[name] = v
        tables[key] = tuple((n, vals[n]) for n in MEASUREMENTS if n in vals)
    if seed is None or len(tables) < 2:
        return None
    return Measurements(seed, tables["noise"], tables["quantization"])


def _check(data, file, variables):
    """``(Scenario or None, problems)`` from the parsed YAML ``data`` of ``file``."""
    chk = Checker(file)
    if not isinstance(data, dict):
        chk.add("", data, "a scenario file must be a YAML mapping")
        return None, chk.problems
    required = ("name", "stop_time")
    chk.mapping(data, "", required, [k for k in TOP_KEYS if k not in required])
    variables = variables if variables is not None else interface_variables()
    base_dir = Path(file).parent
    name = data.get("name")
    if "name" in data and chk.string(name, "name") is not None and not _NAME.fullmatch(name):
        chk.add("name", name, "must match [A-Za-z0-9_.-]+ (it names the results directory)")
    description = data.get("description", "")
    if description is None:
        description = ""
    chk.string(description, "description")
    stop_time = step = None
    if "stop_time" in data:
        stop_time = chk.number(data["stop_time"], "stop_time", low=0.0, strict=True)
    step = chk.number(data.get("step", 1e-4), "step", low=0.0, strict=True)
    if stop_time is not None and step is not None and not _multiple(stop_time, step):
        chk.add("stop_time", data["stop_time"], f"must be a multiple of step = {step!r}")
    every = chk.integer(data.get("controller_every", 1), "controller_every", low=1)
    algorithm = data.get("algorithm", "gauss-seidel")
    if algorithm not in ALGORITHMS:
        chk.add("algorithm", algorithm, f"must be one of {', '.join(ALGORITHMS)}")
    raw_motor, raw_controller = expand_preset(chk, data.get("motor"), data.get("controller"))
    motor = _overrides(chk, raw_motor, "motor", variables, base_dir)
    plant = _overrides(chk, data.get("plant"), "plant", variables, base_dir)
    controller = _overrides(chk, raw_controller, "controller", variables, base_dir)
    mismatch = data.get("mismatch", False)
    if not isinstance(mismatch, bool):
        chk.add("mismatch", mismatch, "must be true or false")
        mismatch = False
    profiles = {"omega_ref": Constant(0.0), "T_load": Constant(0.0)}
    raw = data.get("profiles", {})
    chk.mapping(raw, "profiles", ("psi_ref",), ("omega_ref", "T_load"))
    if isinstance(raw, dict):
        for key in PROFILE_NAMES:
            if key in raw:
                p, probs = parse_profile(raw[key], f"profiles.{key}", str(file))
                chk.problems += probs
                if p is None:
                    profiles.pop(key, None)
                else:
                    profiles[key] = p
    record = _record(chk, data.get("record"), step, variables)
    acceptance = _acceptance(chk, data.get("acceptance"), stop_time)
    measurements = _measurements(chk, data.get("measurements"))
    # the physics, on every value that passed the schema, in the same pass as the schema problems
    plant_only = _plant_motor_names()
    shared = {n: v for n, v in motor.items() if n not in plant_only}
    fields_of = {u: {**{n: f"motor.{n}" for n in (motor if u == "plant" else shared)},
                     **{n: f"{u}.{n}" for n in over}}
                 for u, over in (("plant", plant), ("controller", controller))}
    sc = Scenario(name if isinstance(name, str) else "", description, Path(file), stop_time, step or 1e-4,
                  every or 1, algorithm, MappingProxyType({**motor, **plant}),
                  MappingProxyType({**shared, **controller}),
                  MappingProxyType({k: profiles[k] for k in PROFILE_NAMES if k in profiles}),
                  record, acceptance, measurements, MappingProxyType(motor), mismatch,
                  preset=_preset_name(data.get("motor")))
    problems, notes = physics_check(sc, fields_of)
    problems = chk.problems + [p for p in problems if p not in chk.problems]
    if problems:
        return None, problems
    sweep = data.get("sweep") if isinstance(data.get("sweep"), dict) else {}
    varied = sweep.get("parameters") if isinstance(sweep.get("parameters"), dict) else {}
    swept = any(str(p).startswith(("plant.", "controller.")) for p in varied)  # the variants differ
    notes = _mismatch_notes(sc, plant, controller, str(file), swept) + notes
    return replace(sc, notes=tuple(notes)), []


def _preset_name(raw_motor):
    """The ``preset`` of a ``motor:`` section if it names a library motor, else ""."""
    from satmotor.machine.library import MOTORS

    name = raw_motor.get("preset") if isinstance(raw_motor, dict) else None
    return name if isinstance(name, str) and name in MOTORS else ""


def _mismatch_notes(sc, plant_over, ctrl_over, file, swept=False):
    """One :class:`Note` per motor parameter whose value differs between the plant and the
    controller (none with ``mismatch: true``), or one saying ``mismatch: true`` has nothing to
    allow (not said when ``swept``: a sweep that varies a plant or controller parameter, whose
    variants differ)."""
    from satmotor.interface import MOTOR_PARAMETERS

    notes = []
    for v in MOTOR_PARAMETERS:
        p, c = sc.plant.get(v.name, v.start), sc.controller.get(v.name, v.start)
        if p == c:
            continue
        where = ", ".join(f"{u}.{v.name}" for u, over in (("plant", plant_over), ("controller", ctrl_over))
                          if v.name in over)
        unit = f" {v.unit}" if v.unit not in ("", "1") else ""
        shown = [f"{u} {x!r}{unit}" + ("" if v.name in over or v.name in sc.motor else " (default)")
                 for u, x, over in (("plant", p, plant_over), ("controller", c, ctrl_over))]
        notes.append(Note(file, where, (p, c), f"{shown[0]}, {shown[1]}: the controller's model "
                          "differs from the plant (a mismatch study? say mismatch: true to silence this)"))
    if sc.mismatch:
        if notes or swept:
            return []
        return [Note(file, "mismatch", True, "set to true, but the plant and the controller get the "
                     "same motor parameters")]
    return notes


def _read(path):
    """``(data, problems)`` of a YAML file; never raises."""
    file = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        return None, [Problem(file, "(file)", file, f"cannot read: {exc}")]
    try:
        return _parse(text, file)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "?"
        what = getattr(exc, "problem", None) or str(exc)
        return None, [Problem(file, "(yaml syntax)", where, f"invalid YAML: {what}")]


def _parse(text, file):
    """``(data, problems)`` of the YAML ``text``: a key given twice in one mapping is a problem (file,
    line, key: YAML's last-one-wins would silently drop the first); raises :class:`yaml.YAMLError`."""
    loader = _LOADER(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None, []
        twice = duplicate_keys(node)
        if twice:
            return None, [Problem(file, path, f"line {line}", f"given twice (first on line {first}): the "
                                  "second would silently replace the first; keep one")
                          for path, line, first in twice]
        return loader.construct_document(node), []
    finally:
        loader.dispose()


def duplicate_keys(node, path="", seen=None):
    """``[(key path, line, first line)]`` of the keys a YAML mapping of the node tree ``node`` gives
    twice (lines from 1; a merge key ``<<`` is YAML's own override, not a duplicate)."""
    seen = set() if seen is None else seen
    if id(node) in seen:  # an alias: its node was walked where its anchor is
        return []
    seen.add(id(node))
    out = []
    if isinstance(node, yaml.MappingNode):
        first = {}
        for key, value in node.value:
            if key.tag == "tag:yaml.org,2002:merge":
                continue
            name = key.value if isinstance(key, yaml.ScalarNode) else None
            where = f"{path}.{name}" if path else str(name)
            if name is not None:
                tag = (key.tag, name)
                if tag in first:
                    out.append((where, key.start_mark.line + 1, first[tag]))
                else:
                    first[tag] = key.start_mark.line + 1
            out += duplicate_keys(value, where, seen)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            out += duplicate_keys(item, f"{path}[{i}]", seen)
    return out


def load_scenario(path, variables=None):
    """The :class:`Scenario` of the YAML file ``path``; raises :class:`ScenarioError` listing every
    problem.  ``variables``: ``{"plant": {name: (causality, type)}, "controller": {...}}`` of the
    FMUs (e.g. from fmpy's model descriptions); None: :func:`interface_variables`."""
    data, problems = _read(path)
    if not problems:
        sc, problems = _check(data, str(path), variables)
    if problems:
        raise ScenarioError(problems, str(path))
    return sc

"""The ``sweep:`` section of a scenario file: one scenario becomes many variants, expanded before
anything runs.  Parsed YAML in, variants (parsed YAML again) and problems out; the one file read is a
parameter's prior, ``{from: fit.yaml}`` (:mod:`orchestration.scenario.priors`, relative to the scenario
file; drawn normal from its value and 1-sigma, jointly with its covariance), and ``correlation:`` /
``covariance:`` correlate normal parameters (:mod:`orchestration.scenario.correlation`).

Two kinds, told apart by the key ``samples``::

    sweep:                                # a full grid: every combination of the values listed
      parameters:
        motor.J: [0.0131, 0.0262, 0.0524]                 # a list
        controller.c1: {start: 100, stop: 300, num: 3}    # a range: num values, both ends included
        profiles.T_load.value: {start: 0, stop: 20, step: 10}   # a range by step, stop included

    sweep:                                # Monte Carlo: ``samples`` draws with ``seed``
      samples: 20
      seed: 7
      parameters:
        motor.R_r: {tolerance: 0.1}       # uniform in nominal * [1 - 0.1, 1 + 0.1]
        motor.J: {normal: [0.0131, 0.001]}    # normal, [mean, standard deviation]
        controller.c1: {uniform: [150, 250]}  # uniform in [low, high]

A sensitivity study (``analysis: sobol`` or ``morris``, with ``samples`` and ``seed``; Morris also
``levels``) draws its variants by the method's own design, from the same distributions as a Monte
Carlo sweep (:mod:`orchestration.scenario.designs`: Saltelli's ``N (D + 2)`` variants, ``N`` a power of
two, or ``N`` Morris trajectories of ``D + 1``); the batch then writes the indices
(:mod:`orchestration.study`).

A parameter path is ``motor.NAME``, ``plant.NAME`` or ``controller.NAME`` (a parameter of that
section; :data:`satmotor.interface.MOTOR_PARAMETERS` for ``motor``), or ``profiles.PROFILE.KEY``
(``profiles.PROFILE[i].KEY`` for the i-th part of a summed profile) for a key of a profile the
scenario defines.  The nominal value of a ``tolerance`` is the one the file writes (for
``plant.NAME`` / ``controller.NAME`` of a motor parameter, the unit's own value, else its
``motor:`` value, a ``motor: {preset: ...}`` included), else the FMU's default.  Range values are
``start + i * step`` (or ``start + i (stop - start) / (num - 1)``), rounded to 12 significant
digits so that ``0.1 * 3`` reads 0.3; integer ends and step give integers.  Draws: one
``numpy.random.default_rng(seed)``, ``samples`` values per parameter in the order the file lists them.

Variant ``i`` (from 0) is named ``NAME-iii`` (zero-padded to the width of the count); the grid
varies the last parameter fastest.  A variant is the file's mapping with the sweep removed, its
name changed and its values set; without a ``record: {level: ...}`` it records ``metrics`` only
(:mod:`orchestration.results.recorder`).  The loader (:func:`orchestration.scenario.load.load_sweep`)
checks every variant as a scenario of its own.
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass

from orchestration.scenario import presets
from orchestration.scenario.correlation import JOINT
from orchestration.scenario.problems import MISSING, Checker

__all__ = ["Plan", "Sweep", "Variant", "expand", "plan", "parse_sweep", "plan_sweep", "MAX_VARIANTS",
           "SECTIONS"]

MAX_VARIANTS = 10_000  # a grid beyond this is refused (a typo in a range, not a study)
SECTIONS = ("motor", "plant", "controller", "profiles")
DISTRIBUTIONS = ("uniform", "normal", "tolerance")
CURVE_PARAMETERS = ("L_m0", "L_m_inf", "I_par", "poly_b")  # a prior's curve family must be the unit's
RANGE_KEYS = ("start", "stop", "num", "step")
_PROFILE_PATH = re.compile(r"profiles\.([A-Za-z_]\w*)(?:\[(\d+)\])?\.([A-Za-z_]\w*)")
_REL = 1e-9  # a range's stop is reached when within this relative tolerance


@dataclass(frozen=True)
class Variant:
    """One variant: its index, name, the values of the varied paths, and its scenario mapping."""

    index: int
    name: str
    values: tuple  # ((path, value), ...) in the order of Sweep.parameters
    data: dict | None  # the parsed YAML of this variant, a scenario file without ``sweep:``


@dataclass(frozen=True)
class Sweep:
    kind: str  # "grid", "montecarlo", or a sensitivity analysis: "sobol", "morris"
    parameters: tuple  # the varied paths, in the file's order
    variants: tuple  # Variant, by index
    seed: int | None = None  # Monte Carlo and the analyses only
    design: dict | None = None  # an analysis: orchestration.scenario.designs.Design (SALib's problem, N, ...)


def _unit_tables():
    """``{section: {name: default}}`` of the parameters a path may name (the FMUs' variable tables)."""
    from satmotor.interface import CONTROLLER_PARAMETERS, MOTOR_PARAMETERS, PLANT_PARAMETERS

    ctrl = {v.name: v.start for v in CONTROLLER_PARAMETERS}
    return {"motor": {v.name: v.start for v in MOTOR_PARAMETERS if v.name in ctrl},
            "plant": {v.name: v.start for v in PLANT_PARAMETERS}, "controller": ctrl}


def _round(x):
    return float(f"{x:.12g}")


def _range(chk, spec, where):
    """The values of ``{start, stop, num}`` or ``{start, stop, step}``, or None."""
    extra = [k for k in spec if k not in RANGE_KEYS]
    if extra or "start" not in spec or "stop" not in spec or ("num" in spec) == ("step" in spec):
        chk.add(where, spec, "a range is {start, stop, num} or {start, stop, step} "
                "(exactly one of num, step)")
        return None
    start, stop = chk.number(spec["start"], f"{where}.start"), chk.number(spec["stop"], f"{where}.stop")
    if "num" in spec:
        num = chk.integer(spec["num"], f"{where}.num", low=1)
        if None in (start, stop, num):
            return None
        if num == 1 and start != stop:
            chk.add(f"{where}.num", num, "must be >= 2 when start != stop")
            return None
        if num > MAX_VARIANTS:
            chk.add(f"{where}.num", num, f"must be <= {MAX_VARIANTS}")
            return None
        values = [start] if num == 1 else [_round(start + i * (stop - start) / (num - 1)) for i in range(num)]
        integral = all(isinstance(spec[k], int) and not isinstance(spec[k], bool) for k in ("start", "stop"))
    else:
        step = chk.number(spec["step"], f"{where}.step")
        if None in (start, stop, step):
            return None
        if step == 0 or (stop - start) * step < 0:
            chk.add(f"{where}.step", spec["step"], "must be non-zero and lead from start = "
                    f"{spec['start']!r} to stop = {spec['stop']!r}")
            return None
        count = math.floor((stop - start) / step * (1 + _REL) + _REL) + 1
        if count > MAX_VARIANTS:
            chk.add(where, spec, f"gives {count} values; at most {MAX_VARIANTS}")
            return None
        values = [_round(start + i * step) for i in range(count)]
        integral = all(isinstance(spec[k], int) and not isinstance(spec[k], bool)
                       for k in ("start", "stop", "step"))
    if integral and all(v == int(v) for v in values):
        values = [int(v) for v in values]
    return values


def _grid_values(chk, spec, where):
    if isinstance(spec, list):
        if not spec:
            chk.add(where, spec, "an empty list varies nothing")
            return None
        return list(spec)
    if isinstance(spec, dict) and any(k in spec for k in (*DISTRIBUTIONS, "from")):
        chk.add(where, spec, "a distribution needs sweep.samples (a Monte Carlo sweep); a grid takes a list "
                "or a range {start, stop, num | step}")
        return None
    if isinstance(spec, dict):
        return _range(chk, spec, where)
    chk.add(where, spec, "must be a list of values or a range {start, stop, num | step}")
    return None


def _distribution(chk, spec, where, nominal):
    """``(kind, a, b)`` of a distribution spec, or None: uniform (low, high), normal (mean, std),
    tolerance -> uniform (nominal (1 - r), nominal (1 + r))."""
    if not (isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in DISTRIBUTIONS):
        chk.add(where, spec, "a Monte Carlo parameter is one of {uniform: [low, high]}, "
                "{normal: [mean, std]}, {tolerance: r} (relative, uniform around the nominal value)")
        return None
    (kind, arg), = spec.items()
    if kind == "tolerance":
        r = chk.number(arg, f"{where}.tolerance", low=0.0)
        if r is None:
            return None
        if isinstance(nominal, bool) or not isinstance(nominal, (int, float)) or not math.isfinite(nominal):
            chk.add(f"{where}.tolerance", arg,
                    f"needs a numeric nominal value; the scenario's is {nominal!r}")
            return None
        return "uniform", nominal * (1.0 - r), nominal * (1.0 + r)
    if not (isinstance(arg, list) and len(arg) == 2):
        pair = "[low, high]" if kind == "uniform" else "[mean, std]"
        chk.add(f"{where}.{kind}", arg, f"must be a pair {pair}")
        return None
    a, b = chk.number(arg[0], f"{where}.{kind}[0]"), chk.number(arg[1], f"{where}.{kind}[1]", low=0.0)
    if a is None or b is None:
        return None
    if kind == "uniform" and not a <= b:
        chk.add(f"{where}.uniform", arg, "low must be <= high")
        return None
    return kind, a, b


def _with_preset(data):
    """The file's ``(motor, controller)`` sections with a ``motor: {preset: ...}`` applied (the nominal
    values a tolerance is drawn around); an unknown preset is the loader's problem, not this one's."""
    motor = data.get("motor") if isinstance(data.get("motor"), dict) else {}
    controller = data.get("controller") if isinstance(data.get("controller"), dict) else {}
    motor, controller = presets.expand(Checker("-"), motor, controller)
    return (motor if isinstance(motor, dict) else {}), (controller if isinstance(controller, dict) else {})


def _locate(chk, data, path, tables, spec=None):
    """``(setter, nominal)`` of ``path`` in ``data`` (a function writing a value into a copy of the
    mapping, and the value there now), or None after recording why the path is refused (the
    problem's value: ``spec``, what the file says to vary it over)."""
    section, _, rest = path.partition(".") if isinstance(path, str) else ("", "", "")
    if section in ("motor", "plant", "controller"):
        table = tables.get(section, {})
        if rest not in table:
            chk.add(f"sweep.parameters.{path}", spec, f"{rest!r} is not a {section} parameter; {section}: "
                    + ", ".join(sorted(table)))
            return None
        if section == "controller" and rest == "Ts":
            chk.add(f"sweep.parameters.{path}", spec, "Ts is step * controller_every: vary those instead")
            return None
        motor, controller = _with_preset(data)
        own = {"motor": motor, "controller": controller}.get(section, data.get(section))
        own = own if isinstance(own, dict) else {}
        fallback = motor.get(rest, table[rest]) if rest in tables.get("motor", {}) else table[rest]
        nominal = own.get(rest, fallback)

        def setter(d, v, section=section, name=rest):
            if not isinstance(d.get(section), dict):
                d[section] = {}
            d[section][name] = v
        return setter, nominal
    m = _PROFILE_PATH.fullmatch(path) if isinstance(path, str) else None
    if m is None:
        chk.add(f"sweep.parameters.{path}", spec, "a parameter path is motor.NAME, plant.NAME, "
                "controller.NAME, profiles.PROFILE.KEY or profiles.PROFILE[i].KEY")
        return None
    name, index, key = m.group(1), m.group(2), m.group(3)
    profiles = data.get("profiles") if isinstance(data.get("profiles"), dict) else {}
    spec = profiles.get(name)
    if index is not None:
        spec = spec[int(index)] if isinstance(spec, list) and int(index) < len(spec) else None
    elif isinstance(spec, list):
        spec = None
    if not isinstance(spec, dict):
        chk.add(f"sweep.parameters.{path}", spec, f"the scenario defines no profile {name}"
                + (f"[{index}]" if index is not None else "") + " mapping to vary (a summed profile: "
                "profiles.NAME[i].KEY)")
        return None

    def setter(d, v, name=name, index=index, key=key):
        target = d["profiles"][name]
        (target[int(index)] if index is not None else target)[key] = v
    return setter, spec.get(key)


def parse_sweep(raw, data, file, tables=None, only=None):
    """``(Sweep or None, problems)`` of the ``sweep:`` mapping ``raw`` of the scenario mapping
    ``data`` (from ``file``).  ``tables``: ``{section: {parameter name: default}}`` of the paths
    allowed (default: the FMUs' variable tables).  ``only``: an index; the other variants get no
    mapping (``data`` None: the run of one variant copies the file's mapping once, not per variant)."""
    plan, problems = plan_sweep(raw, data, file, tables)
    return (None, problems) if plan is None else (plan.sweep(only), [])


def plan_sweep(raw, data, file, tables=None):
    """``(Plan or None, problems)`` of the ``sweep:`` mapping ``raw`` of the scenario mapping ``data``
    (as :func:`parse_sweep`): the design drawn, no variant's mapping built yet."""
    chk = Checker(file)
    tables = tables if tables is not None else _unit_tables()
    if not chk.mapping(raw, "sweep", ("parameters",), ("samples", "seed", "analysis", "levels", *JOINT)):
        return None, chk.problems
    params = raw["parameters"]
    if not isinstance(params, dict) or not params:
        chk.add("sweep.parameters", params, "must be a non-empty mapping {parameter path: values}")
        return None, chk.problems
    analysis = _analysis(chk, raw)
    montecarlo = "samples" in raw or analysis is not None
    samples = seed = None
    if montecarlo:
        samples = chk.integer(raw["samples"], "sweep.samples", low=1) if "samples" in raw else None
        if samples is not None and samples > MAX_VARIANTS:
            chk.add("sweep.samples", samples, f"must be <= {MAX_VARIANTS}")
            samples = None
        seed = chk.integer(raw["seed"], "sweep.seed", low=0) if "seed" in raw else None
        if "seed" not in raw:
            chk.add("sweep.seed", MISSING, "a Monte Carlo sweep needs a seed (an integer >= 0): "
                    "the same seed, the same draws")
    elif "seed" in raw:
        chk.add("sweep.seed", raw["seed"], "a seed needs sweep.samples (a Monte Carlo sweep)")
    located, specs, sources, cache = {}, {}, {}, {}
    for path, spec in params.items():
        where = f"sweep.parameters.{path}"
        found = _locate(chk, data, path, tables, spec)
        if found is None:
            continue
        located[path] = found
        if montecarlo and isinstance(spec, dict) and "from" in spec:
            specs[path], sources[path] = _from_prior(chk, spec, where, path, file, cache, data, tables)
        else:
            specs[path] = (_distribution(chk, spec, where, found[1]) if montecarlo
                           else _grid_values(chk, spec, where))
        if analysis == "morris" and specs[path] and specs[path][0] == "normal":
            key = "normal" if "normal" in spec else "from"
            chk.add(f"{where}.{key}", spec[key], "Morris moves on a grid of the unit cube, whose ends "
                    "a "
                    "normal distribution maps to infinity: give {uniform: [low, high]} or {tolerance: r}")
    paths = tuple(params)
    joint = None
    if any(k in raw for k in JOINT) and not montecarlo:
        chk.add("sweep", {k: raw[k] for k in JOINT if k in raw}, "correlated draws need a Monte Carlo "
                "sweep (sweep.samples)")
    elif montecarlo and not chk.problems:
        from orchestration.scenario.correlation import joint_normal

        joint = joint_normal(chk, raw, paths, specs, sources, analysis)
    if analysis is not None and not chk.problems and samples is not None:
        from orchestration.scenario.designs import variant_count

        count = variant_count(analysis, samples, len(paths))
        if count > MAX_VARIANTS:
            chk.add("sweep.samples", samples, f"gives {count} variants ({analysis}, {len(paths)} "
                    "parameters); "
                    f"at most {MAX_VARIANTS}")
    if chk.problems:
        return None, chk.problems
    design = None
    if analysis is not None:
        from orchestration.scenario.designs import draw

        rows, design = draw(analysis, paths, specs, samples, seed, raw.get("levels", 4))
    elif montecarlo and joint is not None:
        from orchestration.scenario.correlation import draws

        rows = draws(paths, specs, joint, samples, seed)
    elif montecarlo:
        import numpy as np

        rng = np.random.default_rng(seed)
        draws = {p: (rng.uniform if kind != "normal" else rng.normal)(a, b, samples).tolist()
                 for p, (kind, a, b) in specs.items()}
        rows = [tuple(draws[p][i] for p in paths) for i in range(samples)]
    else:
        count = math.prod(len(specs[p]) for p in paths)
        if count > MAX_VARIANTS:
            chk.add("sweep.parameters", {p: len(specs[p]) for p in paths},
                    f"a grid of {count} variants; at most {MAX_VARIANTS}")
            return None, chk.problems
        import itertools

        rows = list(itertools.product(*(specs[p] for p in paths)))
    base = {k: v for k, v in data.items() if k != "sweep"}
    kind = analysis or ("montecarlo" if montecarlo else "grid")
    return Plan(kind, paths, rows, tuple(located[p][0] for p in paths), base, seed, design), []


class Plan:
    """A sweep's design drawn once: the varied ``paths``, the ``rows`` of values (one tuple per
    variant), the setters writing them, and the file's mapping without ``sweep:`` (``base``).
    :meth:`variant` builds the mapping of one variant (its cost does not grow with the number of
    variants); :meth:`sweep` the :class:`Sweep` of them all."""

    def __init__(self, kind, paths, rows, setters, base, seed=None, design=None):
        self.kind, self.paths, self.rows, self.setters = kind, paths, rows, setters
        self.base, self.seed, self.design = base, seed, design
        self._width = len(str(len(rows) - 1))

    def __len__(self):
        return len(self.rows)

    def variant(self, i, with_data=True):
        """Variant ``i`` (0 <= i < len(self)); ``with_data`` False: without its mapping (``data`` None)."""
        values = self.rows[i]
        name = f"{self.base.get('name')}-{i:0{self._width}d}"
        if not with_data:
            return Variant(i, name, tuple(zip(self.paths, values)), None)
        d = copy.deepcopy(self.base)
        d["name"] = name
        for setter, v in zip(self.setters, values):
            setter(d, v)
        record = d.get("record")
        if record is None:
            d["record"] = {"level": "metrics"}
        elif isinstance(record, dict) and "level" not in record:
            d["record"] = {**record, "level": "metrics"}
        return Variant(i, name, tuple(zip(self.paths, values)), d)

    def sweep(self, only=None):
        """The :class:`Sweep`; ``only``: as for :func:`parse_sweep`."""
        variants = tuple(self.variant(i, only is None or i == only) for i in range(len(self.rows)))
        return Sweep(self.kind, self.paths, variants, self.seed, self.design)


def _analysis(chk, raw):
    """The ``analysis`` of a sweep (None: a grid or a Monte Carlo sweep), its ``samples`` and ``levels``
    checked; None after recording why not."""
    from orchestration.scenario.designs import ANALYSES, missing_salib

    if "levels" in raw and raw.get("analysis") != "morris":
        chk.add("sweep.levels", raw["levels"], "the grid levels of a Morris study: needs analysis: morris")
    if "analysis" not in raw:
        return None
    analysis = raw["analysis"]
    if analysis not in ANALYSES:
        chk.add("sweep.analysis", analysis, f"must be one of {', '.join(ANALYSES)}")
        return None
    missing = missing_salib()
    if missing:
        chk.add("sweep.analysis", analysis, missing)
        return None
    if "samples" not in raw:
        chk.add("sweep.samples", MISSING, f"a {analysis} study needs samples: " + (
            "N base samples, a power of two (N (D + 2) variants)" if analysis == "sobol" else
            "N trajectories (N (D + 1) variants)"))
        return analysis
    n = raw["samples"]
    if analysis == "sobol" and isinstance(n, int) and not isinstance(n, bool) and (n < 2 or n & (n - 1)):
        chk.add("sweep.samples", n, "the base samples of a Sobol' design must be a power of two >= 2 "
                "(Saltelli's sequence: N (D + 2) variants)")
    if analysis == "morris" and isinstance(n, int) and not isinstance(n, bool) and n < 2:
        chk.add("sweep.samples", n, "a Morris study needs at least 2 trajectories")
    if analysis == "morris" and "levels" in raw:
        lv = raw["levels"]
        if isinstance(lv, bool) or not isinstance(lv, int) or lv < 2 or lv % 2:
            chk.add("sweep.levels", lv, "the Morris grid levels: an even integer >= 2 (default 4)")
    return analysis


def expand(data, file, tables=None, only=None):
    """``(Sweep or None, problems)`` of the scenario mapping ``data``: None without a ``sweep:``
    section (and no problem).  ``only``: as for :func:`parse_sweep`."""
    if not isinstance(data, dict) or "sweep" not in data:
        return None, []
    return parse_sweep(data["sweep"], data, file, tables, only)


def _from_prior(chk, spec, where, path, file, cache, data, tables):
    """``((kind, mean, std), (prior file, name, Prior))`` of ``{from: FILE[, parameter: NAME]}`` (NAME
    defaults to the path's last part), or ``(None, None)`` after recording why
    (:mod:`orchestration.scenario.priors` reads and checks the file)."""
    from pathlib import Path

    from orchestration.scenario import priors

    if not chk.mapping(spec, where, ("from",), ("parameter",)):
        return None, None
    src, name = spec["from"], spec.get("parameter", path.rpartition(".")[2])
    if not isinstance(src, str) or not src:
        chk.add(f"{where}.from", src, "must be the path of a prior file (fit-curve's fit.yaml), relative "
                "to the scenario file")
        return None, None
    if not isinstance(name, str):
        chk.add(f"{where}.parameter", name, "must be the name of a parameter of the prior file")
        return None, None
    full = Path(src) if Path(src).is_absolute() else Path(file).parent / src
    if full not in cache:
        cache[full] = priors.read(full, f"{where}.from", chk, src)
    prior = cache[full]
    if prior is None:
        return None, None
    if name not in prior.values:
        chk.add(f"{where}.from", src, f"{full} has no uncertainty.parameters.{name} (it has: "
                f"{', '.join(prior.values) or 'none'})")
        return None, None
    section = path.partition(".")[0]
    if prior.family is not None and name in CURVE_PARAMETERS and section in ("motor", "plant", "controller"):
        found = _locate(Checker("-"), data, f"{section}.curve", tables)
        curve = found[1] if found is not None else None
        if curve is not None and curve != prior.family:
            chk.add(where, spec, f"{full} holds the {prior.family} curve's {name}; the scenario's "
                    f"{section} curve is {curve!r}: set {section}: {{curve: {prior.family}}} (fit.yaml's "
                    "plant: section)")
            return None, None
    return ("normal", prior.values[name], prior.sigma[name]), (full, name, prior)


def plan(data, file, tables=None):
    """``(Plan or None, problems)`` of the scenario mapping ``data``: None without a ``sweep:``
    section (and no problem)."""
    if not isinstance(data, dict) or "sweep" not in data:
        return None, []
    return plan_sweep(data["sweep"], data, file, tables)

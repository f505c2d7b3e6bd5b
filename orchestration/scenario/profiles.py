"""Time profiles of the scenario inputs: omega_ref [rad/s], psi_ref [Wb], T_load [N m].

A profile is written in YAML as one mapping with a ``type`` key, or as a list of such
mappings whose values are added (:class:`Sum`).  Times are in seconds, values in the unit of
the input they drive.

=========  ===============================================  =====================================
type       keys (default)                                   value(t)
=========  ===============================================  =====================================
constant   value                                            value
step       time, value, initial (0)                         initial for t < time, value from time on
ramp       start, end, to, from (0)                         from, linear to ``to`` at end, held
table      points: [[t0, v0], [t1, v1], ...]                piecewise linear, held beyond the ends
sine       amplitude, frequency [Hz], phase (0) [rad],      0 for t < start, then offset +
           offset (0), start (0)                            amplitude sin(2 pi f (t - start) + phase)
csv        file, time_column (0), value_column (1)          as table, points read from a CSV file
=========  ===============================================  =====================================

Every kind is a frozen dataclass with a fast ``value(t) -> float`` (plain Python floats, called
every step by the master), ``bounds(t0, t1) -> (low, high)`` enclosing its values over
``[t0, t1]`` (exact for every kind but a sum, which adds the parts' bounds), and a classmethod
``parse(mapping, path, file)`` returning ``(profile or None, problems)``: every problem found, as
a :class:`orchestration.scenario.problems.Problem` naming the file, the field path
(``profiles.T_load[1].time``) and the value; nothing is raised.  A CSV file (',', ';' or tab
separators) is read once, at parse time; a relative name is resolved against the directory of
``file`` (the scenario).
"""

from __future__ import annotations

import csv
import math
from bisect import bisect_right
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import ClassVar

from orchestration.scenario.problems import MISSING, Checker, Problem

__all__ = ["Constant", "Step", "Ramp", "Table", "Sine",
           "Csv", "Sum", "KINDS", "parse_profile"]


def _fields(m, path, chk, spec):
    """Check the keys of ``m`` against ``spec`` {key: (default or MISSING, kind)}, kind 'time'
    (finite, >= 0) or 'real' (finite); {key: float}, or None after recording the problems."""
    required = [k for k, (d, _) in spec.items() if d is MISSING]
    if not chk.mapping(m, path, required, ["type"] + [k for k in spec if k not in required]):
        return None
    out = {k: (chk.number(m[k], f"{path}.{k}", low=0.0 if kind == "time" else None) if k in m else d)
           for k, (d, kind) in spec.items()}
    return None if chk.problems else out


def _decimal(x):
    """The exact value of the shortest decimal that reads back as the float ``x``."""
    return Fraction(repr(float(x)))


@dataclass(frozen=True)
class Constant:
    level: float
    kind: ClassVar[str] = "constant"

    def value(self, t):
        return self.level

    def bounds(self, t0, t1):
        return self.level, self.level

    @classmethod
    def parse(cls, m, path, file="<string>"):
        chk = Checker(file)
        f = _fields(m, path, chk, {"value": (MISSING, "real")})
        return (cls(f["value"]) if f else None), chk.problems


@dataclass(frozen=True)
class Step:
    time: float  # [s]
    level: float  # the YAML key 'value'
    initial: float = 0.0
    kind: ClassVar[str] = "step"

    def value(self, t):
        return self.level if t >= self.time else self.initial

    def bounds(self, t0, t1):
        vals = [self.value(t0), self.value(t1)]
        return min(vals), max(vals)

    @classmethod
    def parse(cls, m, path, file="<string>"):
        chk = Checker(file)
        f = _fields(m, path, chk, {"time": (MISSING, "time"), "value": (MISSING, "real"),
                                   "initial": (0.0, "real")})
        return (cls(f["time"], f["value"], f["initial"]) if f else None), chk.problems


@dataclass(frozen=True)
class Ramp:
    """``from`` before ``start``, then ``from + (t - start) slope`` clamped to ``to``.  The slope is
    computed exactly from the shortest decimal forms of the four numbers (as written in YAML) and
    rounded once: 100 / (0.7 - 0.2) gives 200.0, not 200.00000000000003, so the values are those of
    :class:`satmotor.simulate.RampScenario`, bit for bit."""

    start: float  # [s]
    end: float  # [s]
    to: float
    from_: float = 0.0  # the YAML key 'from'
    kind: ClassVar[str] = "ramp"

    def __post_init__(self):
        if not self.end > self.start:
            raise ValueError(f"ramp end = {self.end!r} must be > start = {self.start!r}")
        dec = _decimal  # the slope of the decimal numbers as written, correctly rounded
        slope = float((dec(self.to) - dec(self.from_)) / (dec(self.end) - dec(self.start)))
        self.__dict__.update(_slope=slope, _lo=min(self.from_, self.to), _hi=max(self.from_, self.to))

    def value(self, t):
        if t < self.start:
            return self.from_
        v = self.from_ + (t - self.start) * self._slope
        return self._hi if v > self._hi else (self._lo if v < self._lo else v)

    def bounds(self, t0, t1):  # monotonic
        a, b = self.value(t0), self.value(t1)
        return min(a, b), max(a, b)

    @classmethod
    def parse(cls, m, path, file="<string>"):
        chk = Checker(file)
        f = _fields(m, path, chk, {"start": (MISSING, "time"), "end": (MISSING, "time"),
                                   "to": (MISSING, "real"), "from": (0.0, "real")})
        if f and f["end"] <= f["start"]:
            chk.add(f"{path}.end", m["end"], f"must be > start = {f['start']:g}")
            f = None
        return (cls(f["start"], f["end"], f["to"], f["from"]) if f else None), chk.problems


@dataclass(frozen=True)
class Table:
    """Piecewise linear through ``(times[i], values[i])``, constant beyond the ends."""

    times: tuple
    values: tuple
    kind: ClassVar[str] = "table"

    def value(self, t):
        ts = self.times
        if t <= ts[0]:
            return self.values[0]
        if t >= ts[-1]:
            return self.values[-1]
        i = bisect_right(ts, t)
        t0, v0 = ts[i - 1], self.values[i - 1]
        return v0 + (self.values[i] - v0) * (t - t0) / (ts[i] - t0)

    def bounds(self, t0, t1):  # piecewise linear: the extremes are at the ends or at inner points
        vals = [self.value(t0), self.value(t1)] + [v for t, v in zip(self.times, self.values) if t0 < t < t1]
        return min(vals), max(vals)

    @classmethod
    def parse(cls, m, path, file="<string>"):
        chk = Checker(file)
        if not chk.mapping(m, path, ("points",), ("type",)) or "points" not in m:
            return None, chk.problems
        pts = m["points"]
        if not isinstance(pts, list) or not pts:
            chk.add(f"{path}.points", pts, "must be a non-empty list of [time, value] pairs")
            return None, chk.problems
        times, values = [], []
        for i, p in enumerate(pts):
            where = f"{path}.points[{i}]"
            if not isinstance(p, list) or len(p) != 2:
                chk.add(where, p, "must be a pair [time, value]")
                continue
            t = chk.number(p[0], f"{where}[0]", low=0.0)
            v = chk.number(p[1], f"{where}[1]")
            if t is not None and v is not None:
                if times and t <= times[-1]:
                    chk.add(f"{where}[0]", p[0], f"times must increase strictly (previous {times[-1]:g})")
                times.append(t)
                values.append(v)
        return (None if chk.problems else cls(tuple(times), tuple(values))), chk.problems


@dataclass(frozen=True)
class Sine:
    amplitude: float
    frequency: float  # [Hz]
    phase: float = 0.0  # [rad]
    offset: float = 0.0
    start: float = 0.0  # [s]
    kind: ClassVar[str] = "sine"

    def __post_init__(self):
        self.__dict__["_w"] = 2.0 * math.pi * self.frequency

    def value(self, t):
        if t < self.start:
            return 0.0
        return self.offset + self.amplitude * math.sin(self._w * (t - self.start) + self.phase)

    def bounds(self, t0, t1):
        vals = [self.value(t0), self.value(t1)]
        if t1 > self.start and self._w > 0:  # the crests and troughs inside (max(t0, start), t1)
            a = max(t0, self.start)
            vals.append(self.value(a))
            x0, x1 = self._w * (a - self.start) + self.phase, self._w * (t1 - self.start) + self.phase
            k = math.ceil((x0 - math.pi / 2) / math.pi)
            for j in (k, k + 1):  # two consecutive extremes give both signs
                if j * math.pi + math.pi / 2 < x1:
                    vals.append(self.offset + self.amplitude * (1.0 if j % 2 == 0 else -1.0))
        return min(vals), max(vals)

    @classmethod
    def parse(cls, m, path, file="<string>"):
        chk = Checker(file)
        f = _fields(m, path, chk, {"amplitude": (MISSING, "real"), "frequency": (MISSING, "time"),
                                   "phase": (0.0, "real"), "offset": (0.0, "real"),
                                   "start": (0.0, "time")})
        return (cls(f["amplitude"], f["frequency"], f["phase"], f["offset"], f["start"]) if f else None,
                chk.problems)


def _dialect(text):
    """The CSV dialect of ``text``: ',' unless the sniffer finds ';' or tab separators."""
    try:
        return csv.Sniffer().sniff(text[:4096], delimiters=",;\t")
    except csv.Error:
        return csv.excel


@dataclass(frozen=True)
class Csv:
    """A :class:`Table` read from a CSV file (``file`` as written, resolved against the scenario's
    directory); a first row that is not numeric is a header."""

    file: str
    times: tuple
    values: tuple
    kind: ClassVar[str] = "csv"

    value = Table.value
    bounds = Table.bounds

    @classmethod
    def parse(cls, m, path, file="<string>"):
        chk = Checker(file)
        if not chk.mapping(m, path, ("file",), ("type", "time_column", "value_column")) or "file" not in m:
            return None, chk.problems
        name = chk.string(m["file"], f"{path}.file")
        tc = chk.integer(m.get("time_column", 0), f"{path}.time_column", low=0)
        vc = chk.integer(m.get("value_column", 1), f"{path}.value_column", low=0)
        if chk.problems:
            return None, chk.problems
        if tc == vc:
            chk.add(f"{path}.value_column", vc, "must differ from time_column")
            return None, chk.problems
        base = Path(file).parent if file != "<string>" else Path.cwd()
        resolved = (base / name).resolve()
        where = f"{path}.file"
        try:
            with open(resolved, newline="") as fh:
                text = fh.read()
            rows = list(csv.reader(text.splitlines(), dialect=_dialect(text)))
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            chk.add(where, name, f"cannot read {resolved}: {exc}")
            return None, chk.problems
        times, values = [], []
        for r, row in enumerate(rows, start=1):
            if not any(c.strip() for c in row):
                continue
            if len(row) <= max(tc, vc):
                chk.add(where, name, f"line {r}: {len(row)} column(s) {row!r}, needs column {max(tc, vc)} "
                        "(0-based); separators: ',' ';' or tab")
                break
            try:
                t, v = float(row[tc]), float(row[vc])
            except ValueError:
                if r == 1:
                    continue  # header
                chk.add(where, name, f"line {r}: not numbers: {row[tc]!r}, {row[vc]!r}")
            else:
                if math.isfinite(t) and math.isfinite(v) and t >= 0 and (not times or t > times[-1]):
                    times.append(t)
                    values.append(v)
                    continue
                prev = f" (previous {times[-1]!r})" if times else ""
                chk.add(where, name, f"line {r}: time {t!r}, value {v!r}: values must be finite, times "
                        f"finite, >= 0 and strictly increasing{prev}")
            break
        if not chk.problems and not times:
            chk.add(where, name, f"{resolved} holds no data rows")
        return (None if chk.problems else cls(name, tuple(times), tuple(values))), chk.problems


@dataclass(frozen=True)
class Sum:
    """The sum of profiles."""

    parts: tuple
    kind: ClassVar[str] = "sum"

    def value(self, t):
        s = 0.0
        for p in self.parts:
            s += p.value(t)
        return s

    def bounds(self, t0, t1):
        b = [p.bounds(t0, t1) for p in self.parts]
        return sum(lo for lo, _ in b), sum(hi for _, hi in b)


KINDS = {k.kind: k for k in (Constant, Step, Ramp, Table, Sine, Csv)}


def _parse_one(m, path, file):
    if not isinstance(m, dict):
        return None, [Problem(str(file), path, m, "a profile must be a mapping with a 'type' key "
                              "(or a list of them)")]
    kind = m.get("type", MISSING)
    if not isinstance(kind, str) or kind not in KINDS:
        msg = "required key is missing" if kind is MISSING else "unknown profile type"
        return None, [Problem(str(file), f"{path}.type", kind, f"{msg}; one of {', '.join(KINDS)}")]
    return KINDS[kind].parse(m, path, file)


def parse_profile(spec, path, file="<string>"):
    """A profile from its YAML form (a mapping, or a non-empty list of mappings summed):
    ``(profile or None, problems)``; ``path`` is the field path (``profiles.T_load``)."""
    if isinstance(spec, list):
        if not spec:
            return None, [Problem(str(file), path, spec, "an empty list is not a profile")]
        parts, problems = [], []
        for i, m in enumerate(spec):
            p, probs = _parse_one(m, f"{path}[{i}]", file)
            parts.append(p)
            problems += probs
        if problems:
            return None, problems
        return (parts[0] if len(parts) == 1 else Sum(tuple(parts))), []
    return _parse_one(spec, path, file)

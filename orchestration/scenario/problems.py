"""Problems of an input file, each naming the file, the field and the value: what every validator returns.

:class:`Problem` is one problem (``file: field = value: what is wrong``); :class:`Checker` collects
the problems of one file while its check methods return the checked value (or None after recording
why not), so a validator reports every problem of a file in one pass; :class:`ProblemError` raises
one problem where a caller cannot go on (a profile that SSP cannot express, say); a :class:`Note`
is what a file may do but must not do silently (a plant/controller mismatch, say).  Used by the
scenario loader, the profiles, the FMU builds that embed profiles, and SSP export.
"""

from __future__ import annotations

import math
import re
from typing import NamedTuple

__all__ = ["Problem", "Note", "ProblemError", "MISSING", "Checker"]


class _Missing:
    def __repr__(self):
        return "<missing>"


MISSING = _Missing()  # the value of a Problem about a missing key


class Problem(NamedTuple):
    """One problem of a scenario file: the file, the field path, the offending value, what is wrong."""

    file: str
    field: str
    value: object
    message: str

    def __str__(self):
        v = repr(self.value)
        v = v if len(v) <= 80 else v[:77] + "..."
        return f"{self.file}: {self.field or '(top level)'} = {v}: {self.message}"



class Note(Problem):
    """Something a scenario file does that is allowed but must not pass silently (a plant/controller
    mismatch, a load beyond the current limit's torque): ``FILE: note: FIELD: MESSAGE``."""

    __slots__ = ()

    def __str__(self):
        return f"{self.file}: note: {self.field}: {self.message}"


class ProblemError(ValueError):
    """One :class:`Problem` raised: ``file: field = value: reason`` (the attributes kept)."""

    def __init__(self, file, field, value, reason):
        self.file, self.field, self.value, self.reason = str(file), field, value, reason
        super().__init__(str(Problem(self.file, field, value, reason)))

_YAML_EXP = re.compile(r"^\s*([-+]?)(\d+)(?:\.(\d*))?[eE]([-+]?)(\d+)\s*$")


def _float_hint(s):
    """' (write 1.0e-4)' when the string ``s`` is a number YAML 1.1 read as a string, else ''."""
    try:
        if not math.isfinite(x := float(s)):
            return ""
    except ValueError:
        return ""
    m = _YAML_EXP.match(s)
    if m:
        sign, whole, frac, esign, exp = m.groups()
        return f" (YAML reads it as a string: write {sign}{whole}.{frac or '0'}e{esign or '+'}{exp})"
    return f" (YAML reads it as a string: write {x!r} without quotes)"


class Checker:
    """Collects the problems of one file; the check methods return the checked value or None."""

    def __init__(self, file):
        self.file = str(file)
        self.problems = []

    def add(self, field, value, message):
        self.problems.append(Problem(self.file, field, value, message))

    def number(self, value, field, *, low=None, strict=False):
        """A finite real number (an int or a float, not a bool), optionally ``> low`` (strict) or
        ``>= low``; returns it as a float, or None after recording the problem."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = _float_hint(value) if isinstance(value, str) else ""
            self.add(field, value, f"must be a number, not {type(value).__name__}{hint}")
            return None
        x = float(value)
        if not math.isfinite(x):
            self.add(field, value, "must be finite")
            return None
        if low is not None and (x <= low if strict else x < low):
            self.add(field, value, f"must be {'>' if strict else '>='} {low:g}")
            return None
        return x

    def integer(self, value, field, *, low=None):
        if isinstance(value, bool) or not isinstance(value, int):
            self.add(field, value, f"must be an integer, not {type(value).__name__}")
            return None
        if low is not None and value < low:
            self.add(field, value, f"must be an integer >= {low}")
            return None
        return value

    def string(self, value, field):
        if not isinstance(value, str):
            self.add(field, value, f"must be a string, not {type(value).__name__}")
            return None
        return value

    def mapping(self, value, field, required=(), optional=()):
        """Record a non-mapping, a missing ``required`` key and a key beyond ``required`` +
        ``optional``; True if ``value`` is a mapping (whose keys may still be wrong)."""
        if not isinstance(value, dict):
            self.add(field, value, f"must be a mapping, not {type(value).__name__}")
            return False
        allowed = tuple(required) + tuple(optional)
        for key in value:
            if key not in allowed:
                self.add(_join(field, key), value[key], f"unknown key; allowed: {', '.join(allowed)}")
        for key in required:
            if key not in value:
                self.add(_join(field, key), MISSING, "required key is missing")
        return True


def _join(field, key):
    return f"{field}.{key}" if field else str(key)

"""Measured uncertainty as a sweep's prior: ``{from: fit.yaml}`` (:mod:`orchestration.scenario.sweep`).

The file is ``fit-curve``'s ``fit.yaml`` (or ``commission``'s, the same format); what is read is its
``uncertainty`` section::

    uncertainty:
      family: arctan                       # optional: the magnetizing-curve family the values belong to
      parameters:                          # each parameter's value and 1-sigma [SI]
        L_m0: {value: 0.2772, sigma: 0.0019}
        L_m_inf: {value: 0.0121, sigma: 0.0045}
      covariance:                          # optional: between the parameters named, in this order
        parameters: [L_m0, L_m_inf]
        matrix: [[3.4e-06, -7.1e-06], [-7.1e-06, 2.1e-05]]

A parameter taken ``from:`` the file is drawn normal with that value as its mean and that sigma;
parameters from one file are drawn jointly with the file's covariance.  Every problem names the file,
the field and the value: a missing or unreadable file, a section or a parameter that is not there, a
sigma that is not a finite number >= 0, a matrix that is not square, symmetric, of the sigmas on its
diagonal or positive semi-definite.  :func:`read` caches nothing: one scenario file reads it once per
expansion.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

from orchestration.scenario.problems import Checker

__all__ = ["Prior", "read", "check_matrix"]

_REL = 1e-6  # how far a covariance's diagonal may be from the stated sigma squared (rounding in YAML)


class Prior(NamedTuple):
    file: str
    family: str | None
    values: dict  # {name: value}
    sigma: dict  # {name: 1-sigma}
    names: tuple  # the parameters of ``cov``, in its order (empty: none)
    cov: tuple  # rows of the covariance matrix


def check_matrix(chk, matrix, field, size, diagonal=None, kind="covariance"):
    """The rows of ``matrix`` as floats, checked: ``size`` x ``size``, finite, symmetric, positive
    semi-definite; a ``correlation`` has ones on its diagonal and entries in [-1, 1]; ``diagonal``: the
    variances its diagonal must hold.  None after recording the problem."""
    import numpy as np

    if not (isinstance(matrix, list) and len(matrix) == size
            and all(isinstance(r, list) and len(r) == size for r in matrix)):
        chk.add(field, matrix, f"must be a {size} x {size} matrix (a list of {size} rows of {size} numbers), "
                "one row and column per parameter listed")
        return None
    rows = []
    for a, row in enumerate(matrix):
        vals = [chk.number(x, f"{field}[{a}][{b}]") for b, x in enumerate(row)]
        if None in vals:
            return None
        rows.append(vals)
    for a in range(size):
        for b in range(a):
            if not math.isclose(rows[a][b], rows[b][a], rel_tol=1e-9, abs_tol=1e-300):
                chk.add(f"{field}[{a}][{b}]", matrix[a][b], f"must equal [{b}][{a}] = {matrix[b][a]!r} "
                        "(a symmetric matrix)")
                return None
    for a in range(size):
        want = 1.0 if kind == "correlation" else None if diagonal is None else diagonal[a]
        if want is not None and not math.isclose(rows[a][a], want, rel_tol=_REL, abs_tol=1e-300):
            said = "1 (a correlation)" if kind == "correlation" else f"{want!r} (the sigma squared)"
            chk.add(f"{field}[{a}][{a}]", matrix[a][a], f"must be {said}")
            return None
        if kind == "correlation":
            for b in range(size):
                if abs(rows[a][b]) > 1.0:
                    chk.add(f"{field}[{a}][{b}]", matrix[a][b], "a correlation lies in [-1, 1]")
                    return None
    A = np.array(rows)
    d = np.sqrt(np.maximum(np.diag(A), 0.0))
    scale = np.where(d > 0, d, 1.0)
    low = float(np.linalg.eigvalsh(A / np.outer(scale, scale)).min()) if size else 0.0
    if low < -1e-9:
        chk.add(field, matrix, f"must be positive semi-definite (its smallest eigenvalue, scaled to "
                f"correlations, is {low:.3g}): no distribution has it")
        return None
    return rows


def read(path, field, chk, written=None):
    """The :class:`Prior` of the file ``path`` (``field``: the scenario field that names it, ``written``
    what it says there, for the problems), or None after recording why in ``chk`` (a :class:`Checker`
    of the scenario file)."""
    import yaml

    path = Path(path)
    written = str(path) if written is None else written
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        chk.add(field, written, f"cannot read the prior {path}: {exc.strerror or exc}")
        return None
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        chk.add(field, written, f"the prior {path} is not a YAML file: {str(exc).splitlines()[0]}")
        return None
    own = Checker(str(path))  # the file's own problems name the file and its field
    unc = doc.get("uncertainty") if isinstance(doc, dict) else None
    if not isinstance(unc, dict) or not isinstance(unc.get("parameters"), dict):
        own.add("uncertainty.parameters", unc.get("parameters") if isinstance(unc, dict) else unc,
                "a prior file (fit-curve's fit.yaml) has uncertainty.parameters: {NAME: {value, sigma}}")
        chk.problems += own.problems
        return None
    values, sigma = {}, {}
    for name, spec in unc["parameters"].items():
        where = f"uncertainty.parameters.{name}"
        if not own.mapping(spec, where, ("value", "sigma")):
            continue
        if "value" in spec and "sigma" in spec:
            v = own.number(spec["value"], f"{where}.value")
            s = own.number(spec["sigma"], f"{where}.sigma", low=0.0)
            if v is not None and s is not None:
                values[name], sigma[name] = v, s
    family = unc.get("family")
    if family is not None and not isinstance(family, str):
        own.add("uncertainty.family", family, "must be the name of a curve family")
        family = None
    names, cov = (), ()
    if "covariance" in unc:
        c = unc["covariance"]
        if own.mapping(c, "uncertainty.covariance", ("parameters", "matrix")) and "parameters" in c:
            listed = c["parameters"]
            if not (isinstance(listed, list) and listed and all(n in values for n in listed)
                    and len(set(listed)) == len(listed)):
                own.add("uncertainty.covariance.parameters", listed, "must list parameters of "
                        "uncertainty.parameters, each once: " + ", ".join(values))
            elif "matrix" in c:
                rows = check_matrix(own, c["matrix"], "uncertainty.covariance.matrix", len(listed),
                                    [sigma[n] ** 2 for n in listed])
                if rows is not None:
                    names, cov = tuple(listed), tuple(tuple(r) for r in rows)
    if own.problems:
        chk.problems += own.problems
        return None
    return Prior(str(path), family, values, sigma, names, cov)

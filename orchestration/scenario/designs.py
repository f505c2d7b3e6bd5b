"""The designs of a sensitivity study: which variants to run, drawn by the method's own design
(SALib), from the distributions of the varied parameters.

``sweep: {analysis: sobol | morris, samples: N, seed: S, parameters: {...}}``
(:mod:`orchestration.scenario.sweep` reads the section and calls :func:`draw`):

* ``sobol``: Saltelli's extension of the Sobol' sequence (:func:`SALib.sample.sobol.sample`, first
  and total order, no second order): ``N (D + 2)`` variants for ``D`` varied parameters, ``N`` the
  base samples (a power of two: the sequence's balance properties need it).
* ``morris``: ``N`` Morris trajectories of ``levels`` grid levels (default 4, even;
  :func:`SALib.sample.morris.sample`): ``N (D + 1)`` variants.

A parameter's distribution is what a Monte Carlo sweep takes (``(kind, a, b)``): ``uniform`` (low,
high; a ``tolerance`` is one), or, for ``sobol`` only, ``normal`` (mean, std; SALib's ``norm``; Morris
moves on a grid of the unit cube whose ends a normal maps to infinity).  Pure: numbers in, rows out.
"""

from __future__ import annotations

__all__ = ["ANALYSES", "Design", "problem", "draw", "variant_count", "missing_salib"]

ANALYSES = ("sobol", "morris")
DEFAULT_LEVELS = 4  # Morris grid levels


class Design(dict):
    """What the analysis needs of a design: ``analysis``, ``problem`` (SALib's: ``names``,
    ``bounds``, ``dists``), ``samples`` (N), ``seed``, ``levels`` (Morris)."""


def missing_salib():
    """None when SALib can be imported, else the one line to say (the ``study`` extra)."""
    import importlib.util

    try:
        if importlib.util.find_spec("SALib") is not None:
            return None
    except (ImportError, ValueError):  # a module set to None in sys.modules: not importable
        pass
    return ('a sensitivity study (sweep.analysis) needs SALib, which is not installed: '
            'pip install "satmotor[study]"')


def problem(paths, specs):
    """SALib's problem of the varied ``paths`` with distributions ``specs`` ``{path: (kind, a, b)}``."""
    dists = {"uniform": "unif", "normal": "norm"}
    return {"num_vars": len(paths), "names": list(paths),
            "bounds": [[specs[p][1], specs[p][2]] for p in paths],
            "dists": [dists[specs[p][0]] for p in paths]}


def variant_count(analysis, samples, dimension):
    """How many variants a design of ``samples`` base samples (trajectories) over ``dimension``
    parameters runs."""
    return samples * (dimension + 2 if analysis == "sobol" else dimension + 1)


def draw(analysis, paths, specs, samples, seed, levels=DEFAULT_LEVELS):
    """``(rows, Design)``: the parameter values of every variant (a tuple per variant, in the order
    of ``paths``), by the method's design."""
    import numpy as np

    prob = problem(paths, specs)
    if analysis == "sobol":
        import warnings

        from SALib.sample import sobol

        with warnings.catch_warnings():  # the checks of the sweep say what matters (N a power of 2)
            warnings.simplefilter("ignore")
            X = sobol.sample(prob, samples, calc_second_order=False, scramble=True, seed=seed)
    else:
        from SALib.sample import morris

        X = morris.sample(prob, samples, num_levels=levels, seed=seed)
    X = np.asarray(X, dtype=float)
    rows = [tuple(float(x) for x in row) for row in X]
    return rows, Design(analysis=analysis, problem=prob, samples=samples, seed=seed, levels=levels)

"""The analyses of a sensitivity study: the indices of every metric for every varied parameter,
from the metrics of the variants the design drew (:mod:`orchestration.scenario.designs`), by SALib.

* Sobol' (:func:`SALib.analyze.sobol.analyze`, no second order): ``S1`` the first-order index (the
  share of the metric's variance the parameter explains alone), ``ST`` the total index (with all its
  interactions), each with the half-width of its 95 % bootstrap confidence interval (``S1_conf``,
  ``ST_conf``; 100 resamples, the design's seed).
* Morris (:func:`SALib.analyze.morris.analyze`): ``mu`` the mean elementary effect, ``mu_star`` the
  mean of its absolute value (the importance), ``mu_star_conf`` its 95 % bootstrap half-width,
  ``sigma`` the standard deviation (non-linearity and interactions), in the metric's unit per unit
  range of the parameter (the effect of moving the parameter across its range).

A metric that some variant lacks (a failed run), or, for Sobol', that is the same in every variant
(no variance to share), gets NaN indices and a ``note`` saying why.
"""

from __future__ import annotations

import math

__all__ = ["COLUMNS", "indices", "metric_columns"]

COLUMNS = {"sobol": ("S1", "S1_conf", "ST", "ST_conf"), "morris": ("mu", "mu_star", "mu_star_conf", "sigma")}
_NOT_METRICS = ("variant", "index", "status", "exit_code", "accepted", "holds_setpoints", "wall_time",
                "message")


def metric_columns(df, parameters):
    """The metric columns of a sweep table ``df`` (numeric, not a parameter nor a row field)."""
    import pandas as pd

    skip = {*_NOT_METRICS, *parameters}
    return [c for c in df.columns if c not in skip and pd.api.types.is_numeric_dtype(df[c])]


def _one(design, X, Y):
    """``{column: array per parameter}`` of one metric's values ``Y`` for the design's inputs ``X``."""
    import warnings

    prob, seed = design["problem"], design["seed"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if design["analysis"] == "sobol":
            from SALib.analyze import sobol

            r = sobol.analyze(prob, Y, calc_second_order=False, num_resamples=100, conf_level=0.95, seed=seed)
        else:
            from SALib.analyze import morris

            r = morris.analyze(prob, X, Y, num_resamples=100, conf_level=0.95, num_levels=design["levels"],
                               seed=seed)
    return {c: list(r[c]) for c in COLUMNS[design["analysis"]]}


def indices(sweep, df):
    """The indices of every metric of the sweep table ``df`` (:func:`orchestration.results.sweep_table.
    sweep_frame`, a row per variant in the design's order) for every parameter of ``sweep`` (its
    ``design`` drawn them): a DataFrame with ``metric``, ``parameter``, the method's columns
    (:data:`COLUMNS`) and ``note``."""
    import numpy as np
    import pandas as pd

    design, params = sweep.design, list(sweep.parameters)
    columns = COLUMNS[design["analysis"]]
    X = np.array([[dict(v.values)[p] for p in params] for v in sweep.variants], dtype=float)
    records = []
    for m in metric_columns(df, params):
        Y = pd.to_numeric(df[m], errors="coerce").to_numpy(dtype=float)
        missing = int(np.sum(~np.isfinite(Y)))
        note, values = "", None
        if missing:
            note = f"{missing} of {len(Y)} variants have no finite value: no index"
        elif design["analysis"] == "sobol" and float(np.var(Y)) == 0.0:
            note = "the same in every variant: no variance to share"
        else:
            values = _one(design, X, Y)
        for i, p in enumerate(params):
            row = {"metric": m, "parameter": p}
            row.update({c: (float(values[c][i]) if values is not None else math.nan) for c in columns})
            row["note"] = note
            records.append(row)
    return pd.DataFrame(records, columns=["metric", "parameter", *columns, "note"])

"""``study_summary.csv``: what a study's variants say together, a row per metric and three rows on
the runs themselves.

Per metric: ``n`` (variants with a finite value), ``mean``, ``std``, ``min``, the quantiles ``q05``,
``q25``, ``median``, ``q75``, ``q95``, ``max``; where the scenario bounds it (``acceptance:``, the
bound of the same name), ``bound``, ``outside`` (variants beyond it, a variant without the value
counted outside, as the acceptance check counts it), ``outside_fraction`` and its 95 % Wilson score
interval ``outside_low`` .. ``outside_high`` (the fraction of *all* drawn variants: the estimate of
the probability that the drive is out of bounds), and ``outside_variants``: each by name and
parameters.  The rows ``(failed)`` (a run that did not end ``ok``, with its reason), ``(not held)``
(:mod:`orchestration.results.writer`: the set-points not held) and ``(not accepted)`` (any bound
missed) have the same columns.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

__all__ = ["wilson", "variant_label", "summary_frame", "acceptance_of", "COLUMNS"]

COLUMNS = ("metric", "n", "mean", "std", "min", "q05", "q25", "median", "q75", "q95", "max", "bound",
           "outside", "outside_fraction", "outside_low", "outside_high", "outside_variants")
Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile


def wilson(k, n, z=Z95):
    """``(low, high)``: the Wilson score interval of the fraction ``k / n`` (95 % by default); (nan,
    nan) for n = 0.  It stays inside [0, 1] and is not empty at k = 0 (0 of 20 is not "never")."""
    if n <= 0:
        return math.nan, math.nan
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (0.0 if k == 0 else max(0.0, centre - half)), (1.0 if k == n else min(1.0, centre + half))


def variant_label(v):
    """``NAME (path = value, ...)`` of a :class:`orchestration.scenario.sweep.Variant`."""
    return f"{v.name} (" + ", ".join(f"{p} = {x:.6g}" if isinstance(x, float) else f"{p} = {x!r}"
                                     for p, x in v.values) + ")"


def acceptance_of(directory, names):
    """``{variant name: acceptance dict of its metrics.json}`` (``{bound: {limit, value, pass}}``)."""
    out = {}
    for n in names:
        try:
            out[n] = json.loads((Path(directory) / n / "metrics.json").read_text()).get("acceptance") or {}
        except (OSError, ValueError):
            out[n] = {}
    return out


def _row(metric, values, total, bound, outside):
    import numpy as np

    finite = np.array([x for x in values if isinstance(x, (int, float)) and math.isfinite(x)], dtype=float)
    q = (np.quantile(finite, [0.05, 0.25, 0.5, 0.75, 0.95]).tolist() if len(finite) else [math.nan] * 5)
    row = {"metric": metric, "n": len(finite), "mean": float(finite.mean()) if len(finite) else math.nan,
           "std": float(finite.std(ddof=1)) if len(finite) > 1 else math.nan,
           "min": float(finite.min()) if len(finite) else math.nan,
           "max": float(finite.max()) if len(finite) else math.nan,
           **dict(zip(("q05", "q25", "median", "q75", "q95"), q)), "bound": bound}
    if outside is not None:
        low, high = wilson(len(outside), total)
        row.update(outside=len(outside), outside_fraction=len(outside) / total if total else math.nan,
                   outside_low=low, outside_high=high, outside_variants="; ".join(outside))
    return row


def summary_frame(sweep, df, directory):
    """The summary (a DataFrame, :data:`COLUMNS`) of ``sweep``'s table ``df``
    (:func:`orchestration.results.sweep_table.sweep_frame`), the variants' results in ``directory``."""
    import pandas as pd

    from orchestration.study.analyses import metric_columns

    labels = {v.name: variant_label(v) for v in sweep.variants}
    accept = acceptance_of(directory, [v.name for v in sweep.variants])
    bounds = {}
    for a in accept.values():
        for k, v in a.items():
            bounds.setdefault(k, v.get("limit"))
    total = len(df)
    records = []
    by_name = df.set_index("variant")
    for m in metric_columns(df, sweep.parameters):
        outside = None
        if m in bounds:  # a variant that ran: its own verdict; one without a verdict (failed): outside
            outside = [labels[n] for n in by_name.index
                       if not (accept.get(n, {}).get(m) or {}).get("pass", False)]
        records.append(_row(m, by_name[m].tolist(), total, bounds.get(m), outside))
    failed = [f"{labels[n]}: {r['status']}" + (f", {r['message']}" if r["message"] else "")
              for n, r in by_name.iterrows() if r["status"] != "ok"]
    records.append(_row("(failed)", [], total, None, failed))
    held = [labels[n] for n, r in by_name.iterrows() if r["holds_setpoints"] is False
            or str(r["holds_setpoints"]) == "False"]
    records.append(_row("(not held)", [], total, None, held))
    missed = [labels[n] + ": " + ", ".join(f"{k} = {v['value']:.4g} > {v['limit']:.4g}"
                                          if not isinstance(v["limit"], bool) else f"{k} = {v['value']}"
                                          for k, v in accept[n].items() if not v["pass"])
              for n, r in by_name.iterrows() if r["accepted"] is False or str(r["accepted"]) == "False"]
    if bounds:
        records.append(_row("(not accepted)", [], total, None, missed))
    return pd.DataFrame(records, columns=list(COLUMNS))

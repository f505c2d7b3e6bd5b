"""``sensitivity.png``: a bar chart per metric of a sensitivity study's indices
(:mod:`orchestration.study.analyses`): Sobol' ``S1`` and ``ST`` per parameter with their confidence
intervals, or Morris ``mu_star`` (with its confidence interval) and ``sigma``.  Metrics without
indices (a note) are named in the title instead of drawn."""

from __future__ import annotations

import math
import textwrap

__all__ = ["sensitivity_figure"]

#: the bars of each analysis: (column, its confidence column or None, label, colour)
BARS = {"sobol": (("S1", "S1_conf", "S1 (first order)", "tab:blue"),
                  ("ST", "ST_conf", "ST (total)", "tab:orange")),
        "morris": (("mu_star", "mu_star_conf", "mu* (importance)", "tab:blue"),
                   ("sigma", None, "sigma (interactions)", "tab:orange"))}


def _short(path):
    return path.split(".", 1)[-1] if path.count(".") == 1 else path


def sensitivity_figure(table, analysis, title, path):
    """Draw the indices ``table`` (a DataFrame of :func:`orchestration.study.analyses.indices`) of an
    ``analysis`` into ``path`` (PNG); False when no metric has an index (nothing drawn)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bars = BARS[analysis]
    drawn = [m for m in dict.fromkeys(table["metric"])
             if table[table["metric"] == m][bars[0][0]].notna().any()]
    left = [m for m in dict.fromkeys(table["metric"]) if m not in drawn]
    if not drawn:
        return False
    ncol = min(4, len(drawn))
    nrow = math.ceil(len(drawn) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.3 * ncol, 2.5 * nrow + 0.6), squeeze=False)
    width = 0.38
    for ax, m in zip(axes.flat, drawn):
        rows = table[table["metric"] == m]
        x = list(range(len(rows)))
        for k, (col, conf, label, colour) in enumerate(bars):
            err = rows[conf].tolist() if conf else None
            ax.bar([i + (k - 0.5) * width for i in x], rows[col].tolist(), width, yerr=err, capsize=2,
                   color=colour, label=label)
        ax.set_xticks(x, [_short(p) for p in rows["parameter"]], fontsize=7, rotation=20)
        ax.set_title(m, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.axhline(0.0, color="0.5", lw=0.6)
    for ax in list(axes.flat)[len(drawn):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    said = "\n" + textwrap.fill(f"no index: {', '.join(left)}", 40 * ncol) if left else ""
    fig.suptitle(textwrap.fill(title, 40 * ncol) + said, fontsize=9)
    fig.tight_layout()
    from orchestration.results.atomic import atomic_file

    with atomic_file(path, "wb") as f:
        fig.savefig(f, dpi=90, format="png")
    plt.close(fig)
    return True

"""``efficiency_map.png`` of :mod:`orchestration.tools.efficiency_map`: per flux mode, the efficiency
over the torque-speed plane (contours where the grid allows, the points otherwise; unreachable points
crossed) with the torque envelope (the largest and smallest reachable torque at each speed); the loss
breakdown (each loss, stacked, at every reachable point); and, where both modes ran, the input-power
reduction of ``loss_minimizing`` against ``nominal`` at the points both reached [W]."""

from __future__ import annotations

import numpy as np

from orchestration.results.atomic import atomic_file

__all__ = ["draw"]


def _envelope(ax, d):
    ok = d[d["reachable"]]
    if ok.empty:
        return
    env = ok.groupby("speed")["torque"].agg(["min", "max"]).reset_index()
    ax.plot(env["speed"], env["max"], "k-", lw=1.5, label="torque envelope")
    ax.plot(env["speed"], env["min"], "k-", lw=1.5)


def _efficiency_panel(ax, d, mode, levels):
    grid = d.pivot_table(index="torque", columns="speed", values="efficiency", dropna=False)
    reach = d.pivot_table(index="torque", columns="speed", values="reachable", aggfunc="max", dropna=False)
    z = np.where(reach.to_numpy(dtype=float) > 0, grid.to_numpy(dtype=float), np.nan)
    if z.shape[0] >= 2 and z.shape[1] >= 2 and np.isfinite(z).sum() >= 4:
        cs = ax.contourf(grid.columns, grid.index, np.ma.masked_invalid(z), levels=levels, cmap="viridis")
        ax.figure.colorbar(cs, ax=ax, label="efficiency [1]", format="%.3g")
    ok = d[d["reachable"]]
    sc = ax.scatter(ok["speed"], ok["torque"], c=ok["efficiency"], cmap="viridis", edgecolor="k", s=25,
                    vmin=levels[0], vmax=levels[-1])
    if z.shape[0] < 2 or z.shape[1] < 2:
        ax.figure.colorbar(sc, ax=ax, label="efficiency [1]")
    bad = d[~d["reachable"]]
    ax.scatter(bad["speed"], bad["torque"], marker="x", color="r", label="not reachable")
    _envelope(ax, d)
    ax.set(xlabel="speed set-point [rad/s]", ylabel="load torque [N m]",
           title=f"efficiency, flux_mode {mode}")
    ax.legend(fontsize=7, loc="best")


def _loss_panel(ax, d, losses):
    ok = d[d["reachable"]].reset_index(drop=True)
    bottom = np.zeros(len(ok))
    x = np.arange(len(ok))
    for name in losses:
        v = ok[name].fillna(0.0).to_numpy()
        ax.bar(x, v, bottom=bottom, label=name)
        bottom += v
    every = max(1, -(-len(ok) // 20))  # at most 20 labels
    labels = [f"{s:g}/{t:g} {m[:4]}" for s, t, m in zip(ok["speed"], ok["torque"], ok["flux_mode"])]
    ax.set_xticks(x[::every], labels[::every], fontsize=6, rotation=60, ha="right")
    ax.set(ylabel="loss [W]", title="loss breakdown (reachable points: speed/torque, mode)")
    ax.legend(fontsize=7, ncol=2)


def _gain_panel(ax, d):
    both = d[d["reachable"]].pivot_table(index=["speed", "torque"], columns="flux_mode", values="P_in")
    if not {"nominal", "loss_minimizing"} <= set(both.columns):
        ax.set_axis_off()
        return
    both = both.dropna().reset_index()
    gain = both["nominal"] - both["loss_minimizing"]
    sc = ax.scatter(both["speed"], both["torque"], c=gain, cmap="magma", edgecolor="k", s=40)
    ax.figure.colorbar(sc, ax=ax, label="P_in(nominal) - P_in(loss_minimizing) [W]")
    ax.set(xlabel="speed set-point [rad/s]", ylabel="load torque [N m]", title="loss-minimizing gain")


def draw(table, path, losses):
    """Draw the figure of the map ``table`` (its DataFrame) to ``path``, ``losses`` the loss columns
    stacked in the breakdown; returns ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    modes = list(dict.fromkeys(table["flux_mode"]))
    fig, axes = plt.subplots(2, max(2, len(modes)), figsize=(6 * max(2, len(modes)), 9), squeeze=False)
    eff = table.loc[table["reachable"], "efficiency"].dropna()
    lo, hi = (float(eff.min()), float(eff.max())) if len(eff) else (0.0, 1.0)
    levels = np.linspace(lo, hi if hi > lo else lo + 1e-3, 13)  # one scale for every mode
    for ax, mode in zip(axes[0], modes):
        _efficiency_panel(ax, table[table["flux_mode"] == mode], mode, levels)
    for ax in axes[0][len(modes):]:
        ax.set_axis_off()
    _loss_panel(axes[1][0], table, losses)
    _gain_panel(axes[1][1], table)
    for ax in axes[1][2:]:
        ax.set_axis_off()
    fig.tight_layout()
    with atomic_file(path, "wb") as f:  # never a half-written figure
        fig.savefig(f, format="png", dpi=100)
    plt.close(fig)
    return path

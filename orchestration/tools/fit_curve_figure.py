"""fit-curve's figure ``fit.png`` (matplotlib, Agg): the no-load points, every fitted family, the chosen
fit's 1-sigma band, and the residuals."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def figure(path, source, pts, fits, best):
    """Write ``path``: the points, every family's fit (the chosen one bold, with its 1-sigma band), and
    the residuals in mWb."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    order = np.argsort(pts.i_mu)
    i, psi = pts.i_mu[order], pts.psi_m[order]
    grid = np.linspace(0.0, 1.05 * float(i.max()), 200)
    fig, (ax, ar) = plt.subplots(2, 1, figsize=(7, 7), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    ax.plot(i, psi, "ko", label="no-load points")
    # residual axis: the families within 10x the best RMS set the scale, the others may run off it
    near = [f for f in fits.values() if f.rms <= 10.0 * best.rms] or [best]
    lim = 1.2e3 * max(max(f.max_abs for f in near), 1e-9)
    if best.band is not None:
        mid = np.array([best.curve.psi(float(g)) for g in grid])
        b = best.band(np.maximum(grid, 1e-3 * float(i.max())))
        ax.fill_between(grid, mid * (1.0 - b), mid * (1.0 + b), color="C0", alpha=0.2, lw=0,
                        label="chosen fit +- 1 sigma")
        ar.fill_between(grid, -1e3 * mid * b, 1e3 * mid * b, color="C0", alpha=0.15, lw=0,
                        label="1 sigma of the chosen fit")
    for name, f in sorted(fits.items(), key=lambda kv: kv[1].score()):
        style = "-" if f is best else "--"
        lw = 2.0 if f is best else 1.0
        ax.plot(grid, [f.curve.psi(float(g)) for g in grid], style, lw=lw,
                label=f"{name} (RMS {f.rms * 1e3:.3g} mWb){' chosen' if f is best else ''}")
        ar.plot(i, [1e3 * (f.curve.psi(float(a)) - b) for a, b in zip(i, psi)], style + "o", lw=lw, ms=3,
                label=name + ("" if f in near else " (off scale)"))
    ar.set_ylim(-lim, lim)
    ar.legend(fontsize=7, ncol=2)
    ax.set_ylabel("psi_m [Wb] (peak)")
    ax.set_title(f"Magnetizing curve from {Path(source).name}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ar.axhline(0.0, color="k", lw=0.5)
    ar.set_xlabel("i_mu [A] (peak)")
    ar.set_ylabel("fit - point [mWb]")
    ar.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

"""The figure of a run: references against responses (speed, flux), torque, currents, voltages, i_mu.

Drawn on a :class:`matplotlib.figure.Figure` with the Agg canvas directly: no pyplot (its import,
the backend selection and the global figure manager cost a run command time and give nothing to a
PNG written once).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from orchestration.results import atomic

_COLUMNS = ("time", "plant.psi_r_alpha", "plant.psi_r_beta", "controller.phase", "profile.omega_ref",
            "plant.omega_m", "controller.omega_ref_shaped", "profile.psi_ref", "controller.psi_ref_shaped",
            "plant.T_e", "profile.T_load", "controller.T_load_est", "plant.i_s_alpha", "plant.i_s_beta",
            "controller.v_sd", "controller.v_sq", "controller.v_s_alpha", "controller.v_s_beta", "plant.i_mu",
            "controller.psi_r_hat_alpha", "controller.psi_r_hat_beta", "controller.current_limited",
            "controller.voltage_limited")
#: the plant's DC link: drawn when recorded and on (the link voltage not constant)
_LINK = ("plant.v_dc", "plant.E_regen", "plant.E_chop")


def _mark(ax, t, flags, y, label):
    """Dots at ``y`` where a limiter flag is set (nothing if it never is)."""
    if np.any(flags):
        ax.plot(t[flags], y[flags], ".", ms=1.5, label=label)


def _link(ax, t, link):
    """The DC link, when on: the voltage bound v_dc/sqrt(3) on the voltage panel, the energies
    returned (E_regen) and burnt in the chopper (E_chop) on a right axis of the last panel."""
    v = link["plant.v_dc"]
    if v.size == 0 or np.all(v == v[0]):  # dc_link: ideal (a constant)
        return
    ax[4].plot(t, v / np.sqrt(3.0), "r--", lw=0.9, label="v_dc/sqrt(3) (DC link)")
    ax[4].legend(loc="best", fontsize=7)
    right = ax[5].twinx()  # inside the panel: the figure has no right margin
    for c, style in (("E_regen", "g"), ("E_chop", "m")):
        e = link[f"plant.{c}"]
        right.plot(t, e, style, lw=0.9, label=f"{c} [J, right] ({e[-1]:.4g} J at the end)")
    right.tick_params(axis="y", direction="in", pad=-28, labelsize=7)
    right.legend(loc="center right", fontsize=7)


def canvas():
    """The empty figure and its six axes (what :func:`figure` draws on; nothing depends on the data).
    Fixed margins (those constrained_layout finds for this figure): no layout pass, which would
    measure every text and tick of the six axes once more before drawing (~0.3 s)."""
    fig = Figure(figsize=(9, 13))
    FigureCanvasAgg(fig)
    ax = fig.subplots(6, 1, sharex=True)
    fig.subplots_adjust(left=0.08, right=0.994, bottom=0.036, top=0.982, hspace=0.075)
    return fig, ax


def figure(data, path, title, blank=None):
    """Write a PNG of a recorded run (a DataFrame, or ``{column: array}``, with ``unit.variable``
    columns) to ``path``: the run phase and the shaped references are the controller's outputs.
    ``blank``: a fresh ``canvas()`` made ahead (None: made here)."""
    fig, ax = blank or canvas()
    df = {c: np.asarray(data[c], dtype=float) for c in _COLUMNS}
    t = df["time"]
    phi = np.hypot(df["plant.psi_r_alpha"], df["plant.psi_r_beta"])
    running = df["controller.phase"] == 1
    phi_hat = np.hypot(df["controller.psi_r_hat_alpha"], df["controller.psi_r_hat_beta"])
    i_mag = np.hypot(df["plant.i_s_alpha"], df["plant.i_s_beta"])
    v_mag = np.hypot(df["controller.v_s_alpha"], df["controller.v_s_beta"])

    def where_running(x):  # NaN (a gap in the line) outside the run phase
        return np.where(running, x, np.nan)

    ax[0].plot(t, df["profile.omega_ref"], "k:", label="set-point omega_ref")
    ax[0].plot(t, where_running(df["controller.omega_ref_shaped"]), "k--", lw=0.8, label="shaped reference")
    ax[0].plot(t, df["plant.omega_m"], label="omega_m")
    ax[0].set_ylabel("speed [rad/s]")
    ax[1].plot(t, df["profile.psi_ref"], "k:", label="set-point psi_ref")
    ax[1].plot(t, where_running(df["controller.psi_ref_shaped"]), "k--", lw=0.8, label="shaped reference")
    ax[1].plot(t, phi, label="|psi_r| (plant)")
    if np.max(np.abs(phi_hat - phi)) > 1e-6 * max(np.max(phi), 1e-300):  # an estimate, not the measurement
        ax[1].plot(t, phi_hat, "--", lw=0.9, label="|psi_r_hat| (controller)")
    ax[1].set_ylabel("rotor flux [Wb]")
    ax[2].plot(t, df["plant.T_e"], label="T_e")
    ax[2].plot(t, df["profile.T_load"], label="T_load")
    ax[2].plot(t, df["controller.T_load_est"], "--", label="T_load_est")
    ax[2].set_ylabel("torque [N m]")
    ax[3].plot(t, df["plant.i_s_alpha"], lw=0.6, label="i_s_alpha")
    ax[3].plot(t, df["plant.i_s_beta"], lw=0.6, label="i_s_beta")
    ax[3].plot(t, i_mag, "k", lw=0.9, label="|i_s|")
    _mark(ax[3], t, df["controller.current_limited"] != 0, i_mag, "current limited")
    ax[3].set_ylabel("stator current [A]")
    ax[4].plot(t, where_running(df["controller.v_sd"]), label="v_sd")
    ax[4].plot(t, where_running(df["controller.v_sq"]), label="v_sq")
    ax[4].plot(t, v_mag, "k", lw=0.9, label="|v_s|")
    _mark(ax[4], t, df["controller.voltage_limited"] != 0, v_mag, "voltage limited")
    ax[4].set_ylabel("stator voltage [V]")
    ax[5].plot(t, df["plant.i_mu"], label="|i_mu|")
    ax[5].set_ylabel("magnetizing current [A]")
    if all(c in data for c in _LINK):
        _link(ax, t, {c: np.asarray(data[c], dtype=float) for c in _LINK})
    ax[5].set_xlabel("time t [s]")
    for a in ax:
        a.grid(True, alpha=0.4)
        a.legend(loc="best", fontsize=7)
    fig.suptitle(title, fontsize=10, y=0.996, va="top")
    with atomic.atomic_file(path, "wb") as f:  # a whole PNG or none (a full disk: OSError)
        fig.savefig(f, format="png", dpi=100)

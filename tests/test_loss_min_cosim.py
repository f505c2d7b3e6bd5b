"""The loss-minimizing flux against a brute-force search through the plant FMU (issue 35, item 2).

For a torque and a speed, the closed loop (plant FMU + controller FMU, native FMI 2.0, the project's
master) runs to steady state in flux_mode nominal with a fixed flux set-point, on a grid of set-points
(0.05 Wb apart over the range, then 0.005 Wb apart around the least); each run's loss is the input
power at the terminals, computed here from the plant's outputs (``3/2 v_avg . i_s``, the applied voltage
over each step against the current's mean over it), minus the load's power ``T_load omega_m``, averaged
over the last 0.2 s.  The brute-force optimum is the vertex of the parabola through the least grid point
and its two neighbours.  The run in flux_mode loss_minimizing (the same machine, psi_ref the upper flux)
must settle within 1 % of that flux and within 0.5 % of its loss.  Nothing here uses the controller's
loss model: the losses are the plant's.  Light (10 %) and rated load, both presets, and one case with
core loss in the plant and the same R_fe in the controller's loss model (with integral action: the law's
model knows no core loss, and without it the speed settles 0.2 to 0.5 % low, differently at each flux);
there the flux is held to 2 % only: the loss minimizer's torque is the law's model torque of the measured
(terminal) current, which includes the core branch's current, about 3 % more torque than the shaft's
here, and so a flux 1.5 % high (its loss 0.06 % above the optimum).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orchestration.packaging import fmus
from orchestration.run.master import run
from orchestration.scenario.load import load_scenario

pytestmark = pytest.mark.slow
W = 100.0  # [rad/s] the speed of every case (below base speed: the field weakening does not act)
T_END, WINDOW = 0.8, 0.6  # [s] the run, the start of the averaging window
# preset, rated torque [N m], upper flux psi_ref [Wb] for the loss-minimizing run (above the optimum),
# plant and controller R_fe [Ohm] (0: none), the flux's tolerance [1]
CASES = {
    "default_4kw light": ("default_4kw", 0.1 * 26.71, 1.25, 0.0, 0.01),
    "default_4kw rated": ("default_4kw", 26.71, 1.25, 0.0, 0.01),
    "qu2012_2kw2 light": ("qu2012_2kw2", 0.1 * 14.6, 1.15, 0.0, 0.01),
    "qu2012_2kw2 rated": ("qu2012_2kw2", 14.6, 1.15, 0.0, 0.01),
    "default_4kw half load, core loss": ("default_4kw", 0.5 * 26.71, 1.25, 800.0, 0.02),
}


def _scenario(path, preset, psi_ref, T, mode, psi0, R_fe):
    lm = f", loss_R_fe: {R_fe}" if mode == "loss_minimizing" else ""
    lm += ", c0: 10000.0, d0: 2500.0" if R_fe else ""
    path.write_text(f"""name: loss_min_brute_force
stop_time: {T_END}
step: 1.0e-4
controller_every: 1
motor: {{preset: {preset}}}
plant: {{omega_m0: {W}, psi_r0: {psi0}, R_fe: {R_fe}}}
controller: {{flux_mode: {mode}{lm}}}
profiles:
  psi_ref: {{type: constant, value: {psi_ref}}}
  omega_ref: {{type: constant, value: {W}}}
  T_load: {{type: constant, value: {T}}}
record: {{interval: 1.0e-4}}
""")
    return load_scenario(path)


def _steady(fmu_dir, tmp_path, preset, psi_ref, T, mode, psi0, R_fe, variant="native"):
    """(loss [W], flux [Wb], speed [rad/s]) over the window, from the plant's outputs; the loss infinite
    where the drive does not hold the speed (too little flux for the torque)."""
    sc = _scenario(tmp_path / "case.yaml", preset, psi_ref, T, mode, psi0, R_fe)
    plant, ctrl = fmus.paths(fmu_dir, variant)
    res = run(sc, str(plant), str(ctrl))
    assert res.ok, res.message
    df = res.frame
    t = df["time"].to_numpy()
    ia, ib = df["plant.i_s_alpha"].to_numpy(), df["plant.i_s_beta"].to_numpy()
    va, vb = df["plant.v_avg_alpha"].to_numpy()[1:], df["plant.v_avg_beta"].to_numpy()[1:]
    p_in = 1.5 * (va * 0.5 * (ia[1:] + ia[:-1]) + vb * 0.5 * (ib[1:] + ib[:-1]))
    s = t[1:] > WINDOW + 1e-9
    w = df["plant.omega_m"].to_numpy()[1:][s]
    phi = np.hypot(df["plant.psi_r_alpha"], df["plant.psi_r_beta"]).to_numpy()[1:][s]
    steady = np.ptp(w) < 1e-3 * W and abs(np.mean(w) - W) < 1e-3 * W
    loss = float(np.mean(p_in[s] - T * w)) if steady else np.inf
    return loss, float(np.mean(phi)), float(np.mean(w))


def _brute_force(fmu_dir, tmp_path, preset, T, R_fe):
    """The brute-force optimum (flux [Wb], loss [W]) and the least loss of the grid [W]."""
    def loss(F):
        return _steady(fmu_dir, tmp_path, preset, F, T, "nominal", F, R_fe)

    coarse = {F: loss(F) for F in np.round(np.arange(0.35, 1.2 + 1e-9, 0.05), 4)}
    F0 = min(coarse, key=lambda F: coarse[F][0])
    fine = {F: loss(F) for F in np.round(np.arange(F0 - 0.05, F0 + 0.05 + 1e-9, 0.005), 4)}
    Fs = sorted(fine)
    j = min(range(1, len(Fs) - 1), key=lambda i: fine[Fs[i]][0])
    x = np.array([fine[Fs[i]][1] for i in (j - 1, j, j + 1)])  # the plant's flux of each run
    y = np.array([fine[Fs[i]][0] for i in (j - 1, j, j + 1)])
    a, b, c = np.polyfit(x, y, 2)
    assert a > 0
    x_opt = -b / (2 * a)
    return x_opt, c - b * b / (4 * a), float(min(y))


@pytest.mark.parametrize("case", list(CASES))
def test_the_chosen_flux_is_the_brute_force_optimum(fmu_dir, tmp_path, case):
    preset, T, psi_hi, R_fe, tol = CASES[case]
    F_bf, P_bf, P_grid = _brute_force(fmu_dir, tmp_path, preset, T, R_fe)
    P_lm, F_lm, w = _steady(fmu_dir, tmp_path, preset, psi_hi, T, "loss_minimizing", 0.8, R_fe)
    print(f"\n[loss min] {case}: T = {T:.3f} N m at {w:.3f} rad/s: brute force {F_bf:.4f} Wb, {P_bf:.3f} W "
          f"(least grid point {P_grid:.3f} W); loss_minimizing {F_lm:.4f} Wb "
          f"({(F_lm / F_bf - 1) * 100:+.3f} %), {P_lm:.3f} W ({(P_lm / P_bf - 1) * 100:+.4f} %)")
    assert abs(F_lm / F_bf - 1.0) <= tol
    assert P_lm <= 1.005 * P_bf and P_lm <= 1.005 * P_grid


@pytest.mark.parametrize("variant", ["python", "native-fmi3"])
def test_every_controller_fmu_gives_the_native_steady_state(fmu_dir, tmp_path, variant):
    args = ("qu2012_2kw2", 1.15, 3.65, "loss_minimizing", 0.8, 0.0)
    assert _steady(fmu_dir, tmp_path, *args, variant=variant) == \
        pytest.approx(_steady(fmu_dir, tmp_path, *args), rel=1e-9)


@pytest.mark.parametrize("variant", ["native", "python"])
def test_the_light_load_scenario_lowers_the_flux_and_meets_its_bounds(fmu_dir, variant):
    from orchestration.results.writer import check_acceptance, compute_metrics

    root = Path(__file__).resolve().parents[1]
    sc = load_scenario(root / "scenarios" / "light_load_loss_min.yaml")
    plant, ctrl = fmus.paths(fmu_dir, variant)
    res = run(sc, str(plant), str(ctrl))
    assert res.ok, res.message
    df = res.frame
    t = df["time"].to_numpy()
    phi = np.hypot(df["plant.psi_r_alpha"], df["plant.psi_r_beta"]).to_numpy()
    w = df["plant.omega_m"].to_numpy()

    def at(x):
        return phi[np.searchsorted(t, x)]

    # 10 %: the brute-force optimum of qu2012_2kw2 at 100 rad/s (the test above: 0.4706 Wb); 50 %: risen,
    # still below the nominal 0.95 Wb (the model's optimum 0.870 Wb)
    assert at(1.19) == pytest.approx(0.4706, rel=0.01)
    assert 0.80 < at(2.0) < 0.93
    assert np.min(w[t > 1.2]) > 0.98 * 100.0  # the step is met: the speed dips by less than 2 %
    verdicts = check_acceptance(compute_metrics(df, sc), sc)
    assert verdicts and all(v["pass"] for v in verdicts.values()), verdicts

"""The plain-Python twin of the master: the same units, steps and measurements as the co-simulation,
without FMI.  The co-simulation must match it (same code, same arithmetic).

:func:`plain_reference` steps :class:`satmotor.interface.PlantUnit` and
:class:`~satmotor.interface.ControllerUnit` as :func:`orchestration.run.master.run` steps their FMUs:
time ``t_k = k h``, the controller every ``controller_every`` plant steps with the set-points and
load at ``t_k``, the plant every ``h`` with the voltages held (Gauss-Seidel: the voltages of the
sample just taken; Jacobi: of the previous one) and the load torque at ``t_k``.  The controller's
inputs are wired as :data:`orchestration.scenario.system.DEFAULT_CONNECTIONS`, and a scenario's
``measurements:`` are applied by the same :class:`~orchestration.run.measurement_noise.MeasurementNoise`
as the master's.  Without measurements and plant-only parameters (``B_2``) this is the loop of
:func:`satmotor.simulate.closed_loop` (a test checks the two agree bit for bit).
"""

from __future__ import annotations

from operator import itemgetter

import pandas as pd

from orchestration.run.measurement_noise import MeasurementNoise
from orchestration.run.wiring import resolve
from orchestration.scenario.system import (
    CONTROLLER,
    DEFAULT_CONNECTIONS,
    LINK_VOLTAGE,
    PLANT,
    PROFILE,
    link_on,
)
from satmotor.interface import ControllerUnit, PlantUnit

# co-simulation column -> plain-Python record key (satmotor.simulate.closed_loop's names)
COLUMNS = {
    "plant.i_s_alpha": "i_s_alpha", "plant.i_s_beta": "i_s_beta", "plant.psi_s_alpha": "psi_s_alpha",
    "plant.psi_s_beta": "psi_s_beta", "plant.psi_r_alpha": "psi_r_alpha", "plant.psi_r_beta": "psi_r_beta",
    "plant.omega_m": "omega_m", "plant.theta_m": "theta_m", "plant.T_e": "T_e", "plant.i_mu": "i_mu",
    "controller.v_s_alpha": "v_s_alpha", "controller.v_s_beta": "v_s_beta", "controller.v_sd": "v_sd",
    "controller.v_sq": "v_sq", "controller.e1": "e1", "controller.e2": "e2", "controller.z1": "z1",
    "controller.z2": "z2", "controller.W": "W", "controller.T_load_est": "T_load_est",
    "controller.psi_r_hat_alpha": "psi_r_hat_alpha", "controller.psi_r_hat_beta": "psi_r_hat_beta",
    "controller.omega_ref_shaped": "omega_ref_shaped", "controller.psi_ref_shaped": "psi_ref_shaped",
    "controller.phase": "phase", "controller.voltage_limited": "voltage_limited",
    "controller.current_limited": "current_limited", "controller.singular_limited": "singular_limited",
}


def _controller_inputs(profiles, link=False):
    """``(plant values, t) -> the controller's inputs`` (order of ``ControllerUnit.INPUTS``), from
    the default connections: plant outputs picked by index, profiles evaluated at ``t``; the last,
    ``v_dc``, the plant's link voltage with ``link`` (``connections_for``: a capacitor link), else 0
    (not connected)."""
    outputs = {PLANT: PlantUnit.OUTPUTS, CONTROLLER: ControllerUnit.OUTPUTS}
    if ControllerUnit.INPUTS[-1] != LINK_VOLTAGE:
        raise ValueError(f"the reference expects {LINK_VOLTAGE} as the controller's last input")
    i_link = PlantUnit.OUTPUTS.index(LINK_VOLTAGE)
    srcs = resolve(DEFAULT_CONNECTIONS, CONTROLLER, ControllerUnit.INPUTS[:-1], outputs, profiles)
    if any(s.unit == CONTROLLER for s in srcs):
        raise ValueError("the reference expects the controller fed by the plant and the profiles only")
    n_p = sum(s.unit == PLANT for s in srcs)
    if any(s.unit != PLANT for s in srcs[:n_p]):
        raise ValueError("the reference expects the plant-fed controller inputs first")
    pick = itemgetter(*[s.ref for s in srcs[:n_p]])
    funcs = [s.ref for s in srcs[n_p:] if s.unit == PROFILE]

    def inputs(pv, t):
        return (*pick(pv), *[f(t) for f in funcs], pv[i_link] if link else 0.0)

    return inputs


def plain_reference(scenario):
    """Run ``scenario`` with the plain-Python units; a DataFrame with the co-simulation's column
    names (``time``, :data:`COLUMNS`, the plant's other outputs with a capacitor DC link,
    ``measured.NAME`` with measurements, then the profiles as the controller sampled them), one row per
    controller sample."""
    plant = PlantUnit(dict(scenario.plant))
    ctrl = ControllerUnit({**scenario.controller, "Ts": scenario.Ts})
    prof = {k: p.value for k, p in scenario.profiles.items()}
    load = prof["T_load"]
    link = link_on(scenario.plant)  # the controller measures the link voltage; the metrics read its outputs
    ctrl_inputs = _controller_inputs(prof, link=link)
    meas = getattr(scenario, "measurements", None)
    measure = MeasurementNoise(meas, PlantUnit.OUTPUTS) if meas is not None and meas.signals else None
    jacobi = scenario.algorithm == "jacobi"
    h, N, Ts = scenario.step, scenario.controller_every, scenario.Ts
    n = round(scenario.stop_time / h)
    p_cols = [f"{PLANT}.{v}" for v in PlantUnit.OUTPUTS]
    c_cols = [f"{CONTROLLER}.{v}" for v in ControllerUnit.OUTPUTS]
    m_cols = list(measure.columns) if measure else []
    f_names = sorted(prof)
    f_cols = [f"{PROFILE}.{v}" for v in f_names]
    f_funcs = [prof[v] for v in f_names]
    i_va, i_vb = ControllerUnit.OUTPUTS.index("v_s_alpha"), ControllerUnit.OUTPUTS.index("v_s_beta")
    rows = []
    cv = ctrl.outputs()
    held = cv
    for k in range(n + 1):
        t = k * h
        if k % N == 0:
            pv = plant.outputs()
            mv, mrow = measure(pv) if measure else (pv, ())
            if jacobi:
                held = cv
            ctrl.step(t, Ts, ctrl_inputs(mv, t))
            cv = ctrl.outputs()
            if not jacobi:
                held = cv
            rows.append((t, *pv, *cv, *mrow, *(f(t) for f in f_funcs)))
        if k == n:
            break
        plant.step(t, h, (held[i_va], held[i_vb], load(t)))
    frame = pd.DataFrame(rows, columns=["time", *p_cols, *c_cols, *m_cols, *f_cols], dtype=float)
    more = [c for c in p_cols if c not in COLUMNS] if link else []
    return frame[["time", *COLUMNS, *more, *m_cols, *f_cols]]

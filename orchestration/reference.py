"""The plain-Python closed loop of a scenario: the same units and steps as the co-simulation,
without FMI.  The co-simulation must match it (same code, same arithmetic)."""

from __future__ import annotations

import math

import pandas as pd

from satmotor.interface import ControllerUnit, PlantUnit
from satmotor.simulate import closed_loop

# co-simulation column -> plain-Python record key
COLUMNS = {
    "plant.i_s_alpha": "i_s_alpha", "plant.i_s_beta": "i_s_beta", "plant.psi_s_alpha": "psi_s_alpha",
    "plant.psi_s_beta": "psi_s_beta", "plant.psi_r_alpha": "psi_r_alpha", "plant.psi_r_beta": "psi_r_beta",
    "plant.omega_m": "omega_m", "plant.theta_m": "theta_m", "plant.T_e": "T_e", "plant.i_mu": "i_mu",
    "controller.v_s_alpha": "v_s_alpha", "controller.v_s_beta": "v_s_beta", "controller.v_sd": "v_sd",
    "controller.v_sq": "v_sq", "controller.e1": "e1", "controller.e2": "e2", "controller.z1": "z1",
    "controller.z2": "z2", "controller.W": "W", "controller.T_load_est": "T_load_est",
    "controller.psi_r_hat_alpha": "psi_r_hat_alpha", "controller.psi_r_hat_beta": "psi_r_hat_beta",
    "controller.omega_ref_shaped": "omega_ref", "controller.psi_ref_shaped": "psi_ref",
    "controller.phase": "phase", "controller.voltage_limited": "voltage_limited",
    "controller.current_limited": "current_limited", "controller.singular_limited": "singular_limited",
}


def plain_reference(scenario):
    """Run ``scenario`` with :func:`satmotor.simulate.closed_loop`; a DataFrame with the
    co-simulation's column names (the profiles as sampled by the controller), one row per
    controller sample."""
    plant = PlantUnit(dict(scenario.plant))
    ctrl = ControllerUnit({**scenario.controller, "Ts": scenario.Ts})
    prof = scenario.profiles
    n_sub = max(1, math.ceil(scenario.step / plant.h_int - 1e-9))
    rec = closed_loop(plant.params, ctrl.drive, scenario.stop_time, prof["omega_ref"].value,
                      prof["psi_ref"].value, prof["T_load"].value, n_sub=n_sub, x0=plant.x0,
                      plant_steps=scenario.controller_every)
    frame = pd.DataFrame({"time": rec["t"], **{col: rec[key] for col, key in COLUMNS.items()},
                          "profile.T_load": rec["T_load"], "profile.omega_ref": rec["omega_set"],
                          "profile.psi_ref": rec["psi_set"]})
    return frame

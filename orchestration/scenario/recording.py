"""What a run records: the columns of a row, the ones a scenario's ``record:`` section keeps, and the
ones the metrics and the figure always need (so a scenario's recording size is known before it runs)."""

from __future__ import annotations

from orchestration.scenario.system import COLUMN_PREFIX, CONTROLLER, PLANT, PROFILE

__all__ = ["NEEDED", "recorded_columns", "recorded_selection", "record_steps", "last_row_time"]

# what compute_metrics and the figure read: always recorded, whatever record.outputs lists
NEEDED = ("plant.omega_m", "plant.psi_r_alpha", "plant.psi_r_beta", "plant.i_s_alpha", "plant.i_s_beta",
          "plant.T_e", "plant.i_mu", "controller.v_s_alpha", "controller.v_s_beta", "controller.v_sd",
          "controller.v_sq", "controller.e1", "controller.z1", "controller.W", "controller.T_load_est",
          "controller.phase", "controller.voltage_limited", "controller.current_limited",
          "controller.omega_ref_shaped", "controller.psi_ref_shaped", "controller.psi_r_hat_alpha",
          "controller.psi_r_hat_beta",
          "plant.v_dc", "plant.E_regen", "plant.E_chop", "plant.dc_fault")  # the DC link, last


def recorded_columns(plant_outputs, controller_outputs, profile_names, measured=()):
    """Column names of a row: time, the plant and controller outputs, the profiles, then the
    measured signals (``measured``: their column names, ``measured.NAME``)."""
    return (["time"] + [f"{PLANT}.{v}" for v in plant_outputs]
            + [f"{CONTROLLER}.{v}" for v in controller_outputs] + [f"{PROFILE}.{v}" for v in profile_names]
            + list(measured))


def recorded_selection(scenario, columns):
    """Indices of ``columns`` to record: time, the profiles, the measured signals (``measured.NAME``),
    ``record.outputs`` (all outputs when empty) and the columns the metrics and the figure need."""
    wanted = set(scenario.record.outputs) | set(NEEDED) if scenario.record.outputs else None
    return [i for i, c in enumerate(columns) if c == "time" or c.startswith((PROFILE + ".", COLUMN_PREFIX))
            or wanted is None or c in wanted]


def record_steps(scenario):
    """``(n, every)``: the run's plant steps (``stop_time / step``) and the steps between two
    recorded rows (``record.interval / step``); row ``k`` is recorded when ``k % every == 0``."""
    h = scenario.step
    return round(scenario.stop_time / h), max(1, round(scenario.record.interval / h))


def last_row_time(scenario):
    """[s] the time of the last row a complete run of ``scenario`` records, as the stepping loop
    computes it (``t0 + k h``, ``t0 = 0``)."""
    n, every = record_steps(scenario)
    return 0.0 + (n // every * every) * scenario.step

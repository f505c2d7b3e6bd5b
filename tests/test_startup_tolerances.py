"""The start-up tolerances as controller parameters (premag_fraction, premag_min_fraction,
premag_speed_tol, premag_time_max, premag_boost, premag_gain): the defaults are the drive's
(DriveConfig()), each reaches the drive, and premag_speed_tol decides whether a turning rotor counts as
driven by a load (pre-magnetization current 0.9 I_max) or not."""

from __future__ import annotations

import math

import pytest

from satmotor.control.drive import DriveConfig
from satmotor.interface import CONTROLLER_PARAMETERS, ControllerUnit

NAMES = ("premag_fraction", "premag_min_fraction", "premag_speed_tol", "premag_time_max", "premag_boost",
         "premag_gain")
UNITS = {"premag_fraction": "1", "premag_min_fraction": "1", "premag_speed_tol": "rad/s",
         "premag_time_max": "s", "premag_boost": "1", "premag_gain": "Ohm"}


def test_the_parameters_and_their_defaults():
    table = {v.name: v for v in CONTROLLER_PARAMETERS}
    for name in NAMES:
        assert table[name].start == getattr(DriveConfig(), name) and table[name].unit == UNITS[name]
    assert table["premag_speed_tol"].start == 2.0  # the value the drive had fixed
    assert ControllerUnit({}).drive.dcfg == DriveConfig()


@pytest.mark.parametrize("name, value", [("premag_fraction", 0.7), ("premag_min_fraction", 0.2),
                                         ("premag_speed_tol", 5.0), ("premag_time_max", 0.1),
                                         ("premag_boost", 1.2), ("premag_gain", 40.0)])
def test_each_reaches_the_drive(name, value):
    assert getattr(ControllerUnit({name: value}).drive.dcfg, name) == value


def _premag_current(values, omega_m):
    """The pre-magnetization current reference [A], seen through the loop's first voltage at zero
    current and zero flux: v_sd = R_s i_ref + K_pm (i_ref - 0)."""
    u = ControllerUnit({"premag_gain": 5.0, **values})  # (R_s + K_pm) 0.9 I_max within V_dc/sqrt(3)
    u.step(0.0, 1e-4, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, omega_m, 0.0, 0.95, 0.0, 0.0))  # v_dc last: none
    o = dict(zip(u.OUTPUTS, u.outputs()))
    assert o["phase"] == 0
    return math.hypot(o["v_sd"], o["v_sq"]) / (1.405 + u.drive.dcfg.premag_gain)


def test_premag_speed_tol_decides_whether_a_load_turns_the_rotor():
    # at rest: 1.5 x the magnetizing current of 0.95 Wb (bounded by I_max = 30 A)
    base = _premag_current({}, 0.0)
    assert base == pytest.approx(1.5 * ControllerUnit({}).drive.magnetizing_current(0.95), rel=1e-12)
    # 1.8 rad/s (speed noise of 2 rad/s, say): below the default tolerance, the same current
    assert _premag_current({}, 1.8) == pytest.approx(base, rel=1e-12)
    # with the tolerance at 1 rad/s the drive takes it for a load: 0.9 I_max
    assert _premag_current({"premag_speed_tol": 1.0}, 1.8) == pytest.approx(0.9 * 30.0, rel=1e-12)
    # and a larger tolerance keeps 2.5 rad/s for noise
    assert _premag_current({"premag_speed_tol": 3.0}, 2.5) == pytest.approx(base, rel=1e-12)
    assert _premag_current({}, 2.5) == pytest.approx(0.9 * 30.0, rel=1e-12)

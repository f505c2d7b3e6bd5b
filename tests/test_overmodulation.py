"""Overmodulation (controller ``modulation``): the limited voltage against the inverter's hexagon.

The hexagon is written here from its geometry, not from the code under test: the six active vectors
of a two-level inverter, amplitude-invariant Clarke, lie at 2 V_dc / 3 on the angles k 60 deg
(phase a at 0); its edges have unit normals at 30 deg + k 60 deg, each at the distance
V_dc / sqrt(3) (the apothem) from the centre.  A vector lies on the hexagon where
max_k (v . n_k) = V_dc / sqrt(3).
"""

from __future__ import annotations

import math
import random

import pytest

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig, control
from satmotor.control.modulation import limit_voltage
from satmotor.errors import ParameterError
from satmotor.machine.params import MotorParams

NORMALS = [(math.cos(math.radians(30 + 60 * k)), math.sin(math.radians(30 + 60 * k))) for k in range(6)]
VERTICES = [(math.cos(math.radians(60 * k)), math.sin(math.radians(60 * k))) for k in range(6)]


def hexagon_support(va, vb):
    """max_k v . n_k: V_dc / sqrt(3) on the hexagon's boundary, less inside."""
    return max(va * nx + vb * ny for nx, ny in NORMALS)


def stationary(vd, vq, rho):
    c, s = math.cos(rho), math.sin(rho)
    return c * vd - s * vq, s * vd + c * vq


def test_the_hexagon_of_this_test():
    V_dc = 540.0
    for x, y in VERTICES:  # the vertices 2 V_dc / 3, on the boundary
        assert hexagon_support(2 * V_dc / 3 * x, 2 * V_dc / 3 * y) == pytest.approx(V_dc / math.sqrt(3))
    for nx, ny in NORMALS:  # the flats' mid-points at V_dc / sqrt(3)
        assert hexagon_support(V_dc / math.sqrt(3) * nx, V_dc / math.sqrt(3) * ny) == pytest.approx(
            V_dc / math.sqrt(3))


def test_overmodulation_puts_a_command_outside_onto_the_hexagon_keeping_its_angle():
    rng = random.Random(4)
    n_out = n_between = 0
    for _ in range(5000):
        V_dc = rng.uniform(50, 1500)
        r = V_dc * rng.choice((rng.uniform(0.0, 3.0), rng.uniform(0.55, 0.7)))
        ang, rho = rng.uniform(-math.pi, math.pi), rng.uniform(-7, 7)
        vd, vq = r * math.cos(ang), r * math.sin(ang)
        va, vb = stationary(vd, vq, rho)
        inside = hexagon_support(va, vb) <= V_dc / math.sqrt(3)
        ld, lq, lim = limit_voltage(vd, vq, math.cos(rho), math.sin(rho), V_dc, True)
        la, lb = stationary(ld, lq, rho)
        if inside and hexagon_support(va, vb) < V_dc / math.sqrt(3) * (1 - 1e-12):
            assert not lim and (ld, lq) == (vd, vq)
            n_between += r > V_dc / math.sqrt(3)  # beyond the linear circle, passed unchanged
        elif not inside and hexagon_support(va, vb) > V_dc / math.sqrt(3) * (1 + 1e-12):
            n_out += 1
            assert lim
            assert hexagon_support(la, lb) == pytest.approx(V_dc / math.sqrt(3), rel=1e-12)
            assert math.atan2(lq, ld) == pytest.approx(math.atan2(vq, vd), abs=1e-12)
            assert V_dc / math.sqrt(3) * (1 - 1e-12) <= math.hypot(ld, lq) <= 2 * V_dc / 3 * (1 + 1e-12)
    assert n_out > 1000 and n_between > 100


def test_linear_keeps_the_circle():
    rng = random.Random(5)
    for _ in range(2000):
        V_dc, r, ang = rng.uniform(50, 1500), rng.uniform(0, 2000), rng.uniform(-math.pi, math.pi)
        vd, vq = r * math.cos(ang), r * math.sin(ang)
        ld, lq, lim = limit_voltage(vd, vq, 1.0, 0.0, V_dc, False)
        assert lim == (r > V_dc / math.sqrt(3))
        assert math.hypot(ld, lq) == pytest.approx(min(r, V_dc / math.sqrt(3)), rel=1e-12)


def test_the_law_at_the_limit_applies_the_hexagon_and_keeps_the_linear_direction():
    """control() with a large speed error: the linear law's vector on the circle; the overmodulating
    law's, the same direction, on the hexagon (its stationary output checked against this test's
    hexagon), and longer."""
    p = MotorParams()
    rng = random.Random(6)
    n = 0
    for _ in range(300):
        ang = rng.uniform(-math.pi, math.pi)
        phi = rng.uniform(0.5, 1.0)
        meas = (rng.uniform(-10, 10), rng.uniform(-10, 10), phi * math.cos(ang), phi * math.sin(ang),
                0.0, 0.0, rng.uniform(-300, 300))
        ref = (rng.uniform(0.5, 1.0), 0.0, 0.0, rng.uniform(-300, 300), 0.0, 0.0)
        lin, over = (control(meas, ref, (0.0, 0.0), p, BacksteppingGains(), ControllerConfig(modulation=m))
                     for m in ("linear", "overmodulation"))
        if not over.voltage_limited:
            continue
        n += 1
        V_dc = ControllerConfig().V_dc
        assert lin.voltage_limited
        assert math.hypot(lin.v_s_alpha, lin.v_s_beta) == pytest.approx(V_dc / math.sqrt(3), rel=1e-12)
        assert hexagon_support(over.v_s_alpha, over.v_s_beta) == pytest.approx(V_dc / math.sqrt(3), rel=1e-12)
        assert math.atan2(over.v_s_beta, over.v_s_alpha) == pytest.approx(
            math.atan2(lin.v_s_beta, lin.v_s_alpha), abs=1e-9)
        r_lin = math.hypot(lin.v_s_alpha, lin.v_s_beta)
        assert math.hypot(over.v_s_alpha, over.v_s_beta) >= r_lin * (1 - 1e-12)
    assert n > 50


def test_a_bad_modulation_is_refused_by_name():
    with pytest.raises(ParameterError, match="modulation"):
        ControllerConfig(modulation="six_step")

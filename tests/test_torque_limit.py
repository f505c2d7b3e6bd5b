"""The torque a current limit allows (satmotor.limits) against independent computations: the
textbook formula of a constant inductance, and the plant's own equations at the steady state the
limit describes (the plant inverts its fluxes with its own curve code)."""

import math

import pytest

from satmotor.control.fo_model import to_stationary
from satmotor.errors import ParameterError
from satmotor.limits import torque_limit
from satmotor.machine.magnetics import LinearCurve
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import Plant


@pytest.mark.parametrize("psi, I_max, k", [(0.95, 30.0, 1.0), (0.5, 12.0, 1.0), (0.8, 20.0, 0.7)])
def test_constant_inductance_gives_the_textbook_formula(psi, I_max, k):
    L_m = 0.1722
    p = MotorParams(k=k, curve=LinearCurve(L_m))
    i_sd = psi / (k * L_m)  # the flux current: psi_r = k L_m i_mu_d, i_sd = i_mu_d at steady flux
    i_sq = math.sqrt(I_max**2 - i_sd**2)
    expected = 1.5 * p.n_p * (k * L_m / (p.l_r + k * k * L_m)) * psi * i_sq
    lim = torque_limit(p, psi, I_max)
    assert lim.T_max == pytest.approx(expected, rel=1e-12)
    assert lim.i_sd == pytest.approx(i_sd, rel=1e-12) and lim.i_sq == pytest.approx(i_sq, rel=1e-12)


@pytest.mark.parametrize("psi, I_max", [(0.95, 30.0), (1.15, 30.0), (0.6, 10.0)])
def test_saturated_limit_is_a_steady_state_of_the_plant_at_the_limit(psi, I_max):
    p = MotorParams()  # the default arctan curve
    lim = torque_limit(p, psi, I_max)
    x = to_stationary(p, (psi, lim.i_mu_d, lim.i_mu_q, 0.0), rho=0.0)
    o = Plant(p).outputs(x)
    assert math.hypot(o.i_s_alpha, o.i_s_beta) == pytest.approx(I_max, rel=1e-9)
    assert abs(o.i_r_alpha) < 1e-9 * I_max  # no rotor current along the flux: |psi_r| steady
    assert o.T_e == pytest.approx(lim.T_max, rel=1e-9)  # the plant's 3/2 n_p psi_s x i_s


def test_the_default_motor_at_its_rated_flux():
    lim = torque_limit(MotorParams(), 0.95, 30.0)
    # saturation: less than the constant-inductance figure at the static m of the flux current
    assert 26.71 < lim.T_max < 90.0
    assert torque_limit(MotorParams(), 0.95, 15.0).T_max < lim.T_max


def test_an_unreachable_flux_is_refused():
    with pytest.raises(ParameterError) as info:
        torque_limit(MotorParams(), 5.0, 30.0)
    assert info.value.field == "psi_ref"

"""The equivalent-circuit forms (satmotor/machine/forms.py) against independent computations: the same
steady state from each form's own circuit equations, the Gamma form with saturation against a time
simulation of the plant with l_s = 0, parameters recovered from synthetic no-load and locked-rotor tests."""

from __future__ import annotations

import cmath
import math

import pytest

from satmotor.errors import ParameterError
from satmotor.machine.forms import (
    GammaForm,
    InverseGammaForm,
    LockedRotorTest,
    NoLoadTest,
    TForm,
    from_tests,
    polynomial_from_inductance,
    t_form_of,
)
from satmotor.machine.magnetics import ArctanCurve, LinearCurve
from satmotor.machine.params import MotorParams
from satmotor.machine.plant import OMEGA_M, PSI_R_A, PSI_R_B, Plant

# a linear machine: the default motor's leakages and resistances, L_m of the Simscape preset
T = TForm(1.405, 1.395, 5.839e-3, 4.1e-3, 0.1722)


def par(a, b):
    return a * b / (a + b)


def z_t(R_s, R_r, L_ls, L_lr, L_m, w, s):
    """Stator impedance of the T circuit at angular frequency w [rad/s], slip s."""
    return R_s + 1j * w * L_ls + par(1j * w * L_m, R_r / s + 1j * w * L_lr)


@pytest.mark.parametrize("s", [1.0, 0.3, 0.03, 1e-3, -0.05])
@pytest.mark.parametrize("f", [50.0, 5.0])
def test_gamma_and_inverse_gamma_give_the_t_forms_steady_state(s, f):
    w = 2 * math.pi * f
    z = z_t(T.R_s, T.R_r, T.L_ls, T.L_lr, 0.1722, w, s)
    g = T.to_gamma()
    z_g = g.R_s + par(1j * w * g.curve.L_m0, g.R_R / s + 1j * w * g.L_sigma)  # Gamma circuit
    ig = T.to_inverse_gamma()
    z_ig = ig.R_s + 1j * w * ig.L_sigma + par(1j * w * ig.L_M, ig.R_R / s)  # inverse-Gamma circuit
    assert abs(z_g - z) <= 1e-12 * abs(z)
    assert abs(z_ig - z) <= 1e-12 * abs(z)
    # and back: inverse Gamma -> Gamma is the T form's Gamma
    g2 = ig.to_gamma()
    for a, b in ((g2.R_R, g.R_R), (g2.L_sigma, g.L_sigma), (g2.curve.L_m0, g.curve.L_m0)):
        assert a == pytest.approx(b, rel=1e-13)
    # the motor of each form: the plant's seed parameters
    assert T.to_motor(2, 0.0131).l_s == T.L_ls and g.to_motor(2, 0.0131).l_s == 0.0
    assert ig.to_motor(2, 0.0131).l_r == pytest.approx(g.L_sigma, rel=1e-15)


def test_conversion_of_a_saturating_curve_between_forms_is_refused():
    with pytest.raises(ParameterError, match="curve"):
        TForm(1.0, 1.0, 1e-3, 1e-3, ArctanCurve()).to_gamma()


def test_qu_curve_is_exact():
    c = polynomial_from_inductance(0.34, 0.84, 7)
    assert c.poly_n == 8
    for I in (0.1, 1.0, 3.0, 5.0, 8.0, 20.0):
        psi = c.psi(I)
        assert c.m(I) == pytest.approx(0.34 / (1 + (0.84 * psi) ** 7), rel=1e-13)
        assert psi / (0.34 / (1 + (0.84 * psi) ** 7)) == pytest.approx(I, rel=1e-13)


def test_gamma_form_with_saturation_steady_state_in_the_plant():
    """The Qu 2.2-kW machine in Gamma form, fed 400 V 50 Hz at a held speed (slip 4 %): the plant
    (l_s = 0) against the Gamma circuit's steady state solved here with L_M(|psi_s|) written out."""
    L = lambda psi: 0.34 / (1 + (0.84 * psi) ** 7)  # noqa: E731
    R_s, R_R, L_sig, n_p = 3.7, 2.5, 0.023, 2
    f, s = 50.0, 0.04
    w = 2 * math.pi * f
    V = 400 * math.sqrt(2.0 / 3.0)

    def state(Psi):  # psi_s = Psi (real), everything else follows
        psi_R = Psi / (1 + 1j * s * w * L_sig / R_R)
        i_R = -1j * s * w * psi_R / R_R  # rotor: 0 = R_R i_R + j s w psi_R
        i_s = Psi / L(Psi) - i_R
        return R_s * i_s + 1j * w * Psi, i_s, psi_R

    lo, hi = 0.1, 1.5
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if abs(state(mid)[0]) < V else (lo, mid)
    v, i_s, psi_R = state(0.5 * (lo + hi))
    T_e = 1.5 * n_p * (0.5 * (lo + hi) * i_s).imag  # 3/2 n_p Im(conj(psi_s) i_s), psi_s real

    params = GammaForm(R_s, R_R, L_sig, polynomial_from_inductance(0.34, 0.84, 7)).to_motor(n_p, 1e9)
    plant = Plant(params)
    w_m = (1 - s) * w / n_p
    x = (0.0, 0.0, 0.0, 0.0, w_m, 0.0)
    h, n = 1e-4, 20000
    ph = cmath.phase(v)
    i_amp, phi_amp, te = [], [], []
    for k in range(n):
        t = k * h
        tm = t + 0.5 * h  # the voltage held over the step: its value at the midpoint
        va, vb = V * math.cos(w * tm + ph), V * math.sin(w * tm + ph)
        x = plant.step(t, x, va, vb, 0.0, h, 4)
        x = x[:OMEGA_M] + (w_m,) + x[OMEGA_M + 1:]  # speed held
        if k >= n - 200:
            o = plant.outputs(x)
            i_amp.append(math.hypot(o.i_s_alpha, o.i_s_beta))
            phi_amp.append(math.hypot(x[PSI_R_A], x[PSI_R_B]))
            te.append(o.T_e)
    # the held voltage adds a 10-kHz ripple (about 5 V through L_sigma: a few mA) and scales the fundamental
    # by sinc(w h / 2) (4e-5)
    for got, ref in ((i_amp, abs(i_s)), (phi_amp, abs(psi_R)), (te, T_e)):
        err = max(abs(g - ref) for g in got) / abs(ref)
        print(f"Gamma steady state: relative error {err:.2e}")
        assert err < 2e-3


def test_t_form_of_refers_the_rotor_and_keeps_the_stator_behaviour():
    p = MotorParams(1.405, 1.395 * 0.64, 5.839e-3, 5.839e-3 * 0.64, 0.8, 2, 0.0131, 2.985e-3, ArctanCurve())
    q = t_form_of(p).to_motor(2, 0.0131, 2.985e-3)
    assert q.k == 1.0 and q.R_r == pytest.approx(1.395) and q.l_r == pytest.approx(5.839e-3)
    a, b = Plant(p), Plant(q)
    xa = xb = (0.0,) * 6
    for k in range(500):
        t = k * 1e-4
        va, vb = 300 * math.cos(314.16 * t), 300 * math.sin(314.16 * t)
        xa = a.step(t, xa, va, vb, 2.0, 1e-4)
        xb = b.step(t, xb, va, vb, 2.0, 1e-4)
    oa, ob = a.outputs(xa), b.outputs(xb)
    for u, v in ((oa.i_s_alpha, ob.i_s_alpha), (oa.i_s_beta, ob.i_s_beta), (oa.T_e, ob.T_e),
                 (xa[OMEGA_M], xb[OMEGA_M]), (oa.i_mu, ob.i_mu)):
        assert u == pytest.approx(v, rel=1e-9, abs=1e-12)
    # the rotor flux of the T form is the seed's divided by k
    assert xb[PSI_R_A] == pytest.approx(xa[PSI_R_A] / 0.8, rel=1e-9)


@pytest.mark.parametrize("ratio", [1.0, 1.5, 7.0 / 3.0])
def test_from_tests_recovers_the_machine(ratio):
    R_s, R_r, L_ls, L_m = 1.405, 1.395, 5.0e-3, 0.1722
    L_lr = ratio * L_ls

    def measure(V_ll, f, s):
        z = z_t(R_s, R_r, L_ls, L_lr, L_m, 2 * math.pi * f, s)
        I = V_ll / math.sqrt(3) / abs(z)
        return V_ll, I, 3 * I * I * z.real, f

    nl = NoLoadTest(*measure(400.0, 50.0, 1e-15))  # synchronous: the rotor branch carries nothing
    lr = LockedRotorTest(*measure(90.0, 12.5, 1.0))
    t = from_tests(R_s, nl, lr, ratio)
    assert t.L_ls == pytest.approx(L_ls, rel=1e-9)
    assert t.L_lr == pytest.approx(L_lr, rel=1e-9)
    assert t.curve.L_m0 == pytest.approx(L_m, rel=1e-9)
    assert t.R_r == pytest.approx(R_r, rel=1e-9)
    assert isinstance(t.curve, LinearCurve)


def test_from_tests_refuses_inconsistent_data_by_name():
    nl = NoLoadTest(400.0, 4.0, 100.0, 50.0)
    with pytest.raises(ParameterError, match="locked_rotor.P_in"):
        from_tests(1.0, nl, LockedRotorTest(90.0, 10.0, 1e5, 12.5))
    with pytest.raises(ParameterError, match="no_load.I_rms"):
        from_tests(1.0, NoLoadTest(400.0, 0.0, 100.0, 50.0), LockedRotorTest(90.0, 10.0, 500.0, 12.5))
    with pytest.raises(ParameterError, match="locked_rotor"):  # rotor resistance eaten by R_s
        from_tests(5.0, nl, LockedRotorTest(90.0, 10.0, 1200.0, 12.5))


def test_inverse_gamma_example_converts_to_positive_parameters():
    g = InverseGammaForm(3.7, 2.1, 0.021, 0.224).to_gamma()
    assert g.L_sigma > 0.021 and g.curve.L_m0 == pytest.approx(0.245) and g.R_R > 2.1


def test_plant_with_l_s_zero_is_the_limit_of_small_l_s():
    """The Gamma branch (l_s = 0) against the T branch with a tiny l_s: the outputs converge linearly."""
    curve = polynomial_from_inductance(0.34, 0.84, 7)
    x = (0.9, -0.3, 0.85, -0.35, 120.0, 0.0)
    ref = Plant(MotorParams(3.7, 2.5, 0.0, 0.023, 1.0, 2, 0.015, 0.0, curve)).outputs(x)
    errs = []
    for l_s in (1e-5, 1e-6):
        o = Plant(MotorParams(3.7, 2.5, l_s, 0.023, 1.0, 2, 0.015, 0.0, curve)).outputs(x)
        errs.append(max(abs(a - b) / max(abs(b), 1e-3) for a, b in zip(o, ref)))
    assert errs[1] < 1e-3 and errs[1] < 0.2 * errs[0]

"""Magnetizing curves and dynamic inductances against independent computations."""

import math

import numpy as np
import pytest
from conftest import no_load_table
from scipy.integrate import quad
from scipy.interpolate import PchipInterpolator

from satmotor.errors import ParameterError
from satmotor.machine.magnetics import (
    ArctanCurve,
    ExponentialCurve,
    LinearCurve,
    PolynomialCurve,
    dynamic_inductances,
)
from satmotor.machine.params import MotorParams, RatedData, make_curve
from satmotor.machine.table_curve import TableCurve

CURRENTS = [0.0, 1e-9, 1e-4, 0.003, 0.05, 0.4, 1.0, 2.5, 3.0, 4.5, 5.7, 8.0, 12.0, 25.0, 60.0]


def central(f, x, h):
    return (f(x + h) - f(x - h)) / (2.0 * h)


def test_m_at_zero_is_finite_and_the_initial_slope(curve):
    m0 = curve.m(0.0)
    assert math.isfinite(m0) and m0 > 0
    assert math.isfinite(curve.dm_dI(0.0))
    # the initial slope of psi(I), from a one-sided difference far below the knee
    h = 1e-7
    assert curve.psi(h) / h == pytest.approx(m0, rel=1e-6)
    assert curve.L_dyn(0.0) == pytest.approx(m0, rel=1e-12)
    # m is continuous at 0 from the right
    assert curve.m(1e-12) == pytest.approx(m0, rel=1e-10)


def test_m_decreases_past_the_knee(saturating_curve):
    i = np.linspace(2.0, 40.0, 200)
    m = np.array([saturating_curve.m(v) for v in i])
    assert np.all(np.diff(m) < 0)
    # and the curve is strictly increasing everywhere
    psi = np.array([saturating_curve.psi(v) for v in np.linspace(0, 60, 600)])
    assert np.all(np.diff(psi) > 0)


@pytest.mark.parametrize("I", CURRENTS)
def test_inverse_round_trips(curve, I):
    psi = curve.psi(I)
    assert curve.current(psi) == pytest.approx(I, rel=1e-12, abs=1e-15)


# off the table's knots, where the piecewise cubic's second derivative jumps
@pytest.mark.parametrize("I", [0.003, 0.05, 0.4, 1.23, 2.57, 3.3, 4.5, 5.7, 8.2, 12.5, 25.0, 60.0])
def test_derivatives_against_central_differences(curve, I):
    h = 1e-5 * max(I, 1.0) if I > 1e-2 else 1e-6
    assert curve.dm_dI(I) == pytest.approx(central(curve.m, I, h), rel=1e-7, abs=1e-10)
    assert curve.L_dyn(I) == pytest.approx(central(curve.psi, I, h), rel=1e-7)
    # m = psi / I computed independently
    assert curve.m(I) == pytest.approx(curve.psi(I) / I, rel=1e-13)
    # L_dyn = m + I dm/dI
    assert curve.L_dyn(I) == pytest.approx(curve.m(I) + I * curve.dm_dI(I), rel=1e-9)


@pytest.mark.parametrize("I", [0.3, 3.0, 5.7, 20.0])
def test_energy_and_coenergy_are_integrals(curve, I):
    knots = [v for v in getattr(curve, "i_mu", ()) if 0 < v < I] or None  # table: L_dyn has kinks
    co, _ = quad(curve.psi, 0.0, I, epsabs=0, epsrel=1e-13, limit=200, points=knots)
    assert curve.coenergy(I) == pytest.approx(co, rel=1e-11)
    en, _ = quad(lambda x: x * curve.L_dyn(x), 0.0, I, epsabs=0, epsrel=1e-13, limit=200, points=knots)
    assert curve.energy(I) == pytest.approx(en, rel=1e-10)


@pytest.mark.parametrize("a", [0.0, 2.9e-3, 0.05, 1.0])
@pytest.mark.parametrize("c", [1e-9, 0.01, 0.5, 1.0, 1.6, 5.0])
def test_solve_residual(curve, a, c):
    I, psi = curve.solve(a, c)
    assert psi == pytest.approx(curve.psi(I), rel=1e-13)
    assert a * I + psi == pytest.approx(c, rel=1e-13)


@pytest.mark.parametrize("imd,imq", [(5.0, 0.0), (0.0, 4.0), (3.0, -4.0), (-2.0, 6.5), (1e-3, 2e-3)])
def test_dynamic_inductances_are_the_jacobian(curve, imd, imq):
    """M = d(m(|i|) i)/di, by central differences of the vector map (independent of eqs 20-22)."""

    def lam(d, q):
        m = curve.m(math.hypot(d, q))
        return np.array([m * d, m * q])

    h = 1e-6
    col_d = (lam(imd + h, imq) - lam(imd - h, imq)) / (2 * h)
    col_q = (lam(imd, imq + h) - lam(imd, imq - h)) / (2 * h)
    Md, Mq, Mdq, m, dm, ldyn = dynamic_inductances(curve, imd, imq)
    scale = curve.m(0.0)
    assert Md == pytest.approx(col_d[0], abs=1e-7 * scale)
    assert Mq == pytest.approx(col_q[1], abs=1e-7 * scale)
    assert Mdq == pytest.approx(col_q[0], abs=1e-7 * scale)
    assert Mdq == pytest.approx(col_d[1], abs=1e-7 * scale)
    # eigenvalues m (across) and L_dyn (along), so det M = m L_dyn (errata)
    assert Md * Mq - Mdq**2 == pytest.approx(m * ldyn, rel=1e-9)


def test_dynamic_inductances_at_zero_current(curve):
    Md, Mq, Mdq, m, _, _ = dynamic_inductances(curve, 0.0, 0.0)
    assert (Md, Mq, Mdq) == (m, m, 0.0) and math.isfinite(m)


def test_table_matches_scipy_pchip_on_mirrored_points():
    i, psi = no_load_table()
    t = TableCurve(i, psi)
    x = np.array((0.0,) + i)
    y = np.array((0.0,) + psi)
    ref = PchipInterpolator(np.concatenate([-x[:0:-1], x]), np.concatenate([-y[:0:-1], y]))
    grid = np.linspace(0, x[-1], 1001)
    ours = np.array([t.psi(v) for v in grid])
    assert np.max(np.abs(ours - ref(grid))) < 1e-13
    dours = np.array([t.L_dyn(v) for v in grid])
    assert np.max(np.abs(dours - ref.derivative()(grid))) < 1e-12
    # beyond the last point: a straight line with the end slope
    d_end = float(ref.derivative()(x[-1]))
    assert t.psi(x[-1] + 3.0) == pytest.approx(y[-1] + 3.0 * d_end, rel=1e-13)


def test_table_reads_csv(tmp_path):
    i, psi = no_load_table()
    f = tmp_path / "noload.csv"
    f.write_text("i_mu,psi_m\n" + "\n".join(f"{a!r},{b!r}" for a, b in zip(i, psi)))
    t = TableCurve.from_csv(f)
    assert t.psi(4.0) == pytest.approx(TableCurve(i, psi).psi(4.0), rel=1e-15)
    assert make_curve("table", table_file=str(f)).psi(4.0) == t.psi(4.0)


@pytest.mark.parametrize(
    "build,field",
    [
        (lambda: ArctanCurve(L_m0=-0.1), "L_m0"),
        (lambda: ArctanCurve(L_m_inf=0.0), "L_m_inf"),
        (lambda: ArctanCurve(L_m_inf=0.5), "L_m_inf"),
        (lambda: ArctanCurve(I_par=float("nan")), "I_par"),
        (lambda: ExponentialCurve(I_par=0.0), "I_par"),
        (lambda: PolynomialCurve(poly_n=1), "poly_n"),
        (lambda: PolynomialCurve(poly_b=-1.0), "poly_b"),
        (lambda: LinearCurve(0.0), "L_m0"),
        (lambda: TableCurve((1.0, 2.0, 2.0), (0.2, 0.3, 0.4)), "i_mu[3]"),
        (lambda: TableCurve((1.0, 2.0, 3.0), (0.2, 0.3, 0.25)), "psi_m[3]"),
        (lambda: TableCurve((1.0, 2.0), (0.2,)), "psi_m"),
        (lambda: TableCurve((1.0,), (0.2,)), "i_mu"),
        (lambda: TableCurve((0.0, 1.0, 2.0), (0.1, 0.3, 0.4)), "psi_m"),
        (lambda: TableCurve((-1.0, 1.0, 2.0), (0.1, 0.3, 0.4)), "i_mu"),
        (lambda: make_curve("tanh"), "curve"),
        (lambda: make_curve("table"), "table_file"),
        (lambda: make_curve("table", table_file="/nonexistent/noload.csv"), "table_file"),
        (lambda: MotorParams(R_s=0.0), "R_s"),
        (lambda: MotorParams(n_p=1.5), "n_p"),
        (lambda: MotorParams(B=-1.0), "B"),
    ],
)
def test_bad_curves_and_parameters_are_rejected_by_name(build, field):
    with pytest.raises(ParameterError) as err:
        build()
    assert err.value.field == field
    assert field.split("[")[0] in str(err.value)


def test_default_motor_rated_flux_sits_in_the_knee():
    c, r = MotorParams().curve, RatedData()
    m = c.m(r.I_mu_n)
    assert m == pytest.approx(0.1722, rel=2e-3)  # the Simscape preset's unsaturated L_m
    ratio = c.L_dyn(r.I_mu_n) / m
    assert 0.3 < ratio < 0.6  # neither linear (1) nor deep saturation
    assert c.psi(r.I_mu_n) == pytest.approx(r.V_phase_peak / r.omega_e, rel=0.1)

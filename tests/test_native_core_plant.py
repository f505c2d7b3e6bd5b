"""The native C core (fmu/native/core: curves and stationary plant) against the Python package, which is
the specification: thousands of seeded random points per function, relative agreement within 1e-12
(the worst difference of each function is printed: run with -s), the parameter checks with the
ParameterError's field, value and text, and one build under -fsanitize=address,undefined."""

from __future__ import annotations

import ctypes
import math
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from satmotor.errors import ParameterError
from satmotor.interface import PlantUnit
from satmotor.machine.magnetics import inductance_matrix
from satmotor.machine.params import MotorParams, make_curve
from satmotor.machine.plant import Plant, initial_state
from satmotor.machine.table_curve import TableCurve

sys.path.insert(0, str(Path(__file__).resolve().parent))
import native_core as nc  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

TOL = 1e-12
FLOOR = 1e-300  # relative differences: |c - py| / max(|py|, FLOOR)
NO_LOAD = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.5, 9.0, 11.0, 14.0, 18.0)


def _record(name, c, py, floor=FLOOR):
    c, py = np.asarray(c, dtype=float), np.asarray(py, dtype=float)
    assert c.shape == py.shape
    both_nan = np.isnan(c) & np.isnan(py)
    rel = np.where(both_nan, 0.0, np.abs(c - py) / np.maximum(np.abs(py), floor))
    rel = np.where(np.isnan(rel), np.inf, rel)
    worst = float(np.max(rel)) if rel.size else 0.0
    print(f"worst relative difference {name}: {worst:.3g} over {rel.size} values")
    where = int(np.argmax(rel))
    assert worst <= TOL, f"{name}: C and Python differ by {worst:.3g} (relative) at index {where}"


@pytest.fixture(scope="session")
def lib():
    return nc.load()


@pytest.fixture(scope="module")
def table_csv(tmp_path_factory):
    d = tmp_path_factory.mktemp("tables")
    f = d / "no_load.csv"
    psi = tuple(0.012 * x + 0.945 * x / (3.0 + x) for x in NO_LOAD)
    f.write_text("i_mu,psi_m\n" + "\n".join(f"{a!r},{b!r}" for a, b in zip(NO_LOAD, psi)) + "\n")
    # the same kind of table with an origin line, a comment, blank lines, CRLF and a BOM
    g = d / "with_origin.csv"
    rows = [f"{a!r}, {b!r}  # point" for a, b in zip((0.0,) + NO_LOAD, (0.0,) + tuple(1.1 * p for p in psi))]
    g.write_bytes(("\ufeff# no-load test\r\n\r\ncurrent,flux\r\n" + "\r\n".join(rows)).encode("utf-8"))
    return f, g


def curve_cases(table_csv):
    f, g = table_csv
    return [
        ("arctan", {}),
        ("arctan", dict(L_m0=0.5, L_m_inf=0.05, I_par=1.2)),
        ("exponential", dict(L_m0=0.330, L_m_inf=0.01, I_par=3.66)),
        ("exponential", dict(L_m0=0.2, L_m_inf=0.02, I_par=5.0)),
        ("polynomial", {}),
        ("polynomial", dict(L_m0=0.3, poly_b=10.0, poly_n=11)),
        ("polynomial", dict(L_m0=0.2772, poly_b=0.0, poly_n=3)),
        ("polynomial", dict(L_m0=0.34, poly_b=0.84**7 / 0.34, poly_n=8)),  # Qu et al. 2012 (even n)
        ("polynomial", dict(L_m0=0.3, poly_b=1.5, poly_n=2)),
        ("linear", dict(L_m0=0.1722)),
        ("table", dict(table_file=str(f))),
        ("table", dict(table_file=str(g))),
    ]


def c_curve(lib, name, kw):
    full = dict(L_m0=0.2772, L_m_inf=0.01, I_par=3.31, poly_b=2.46, poly_n=7, table_file="")
    full.update(kw)
    c, msg = nc.new_curve(lib), ctypes.create_string_buffer(1024)
    st = lib.sm_curve_init(c, name.encode(), full["L_m0"], full["L_m_inf"], full["I_par"], full["poly_b"],
                           full["poly_n"], full["table_file"].encode(), msg, 1024)
    assert st == 0, msg.value.decode()
    return c


def currents(rng, n, extra=()):
    return np.concatenate([[0.0, 5e-324, 1e-300, 1e-12, 1e-8, 1e-6, 1e-3, 0.0331, 0.0732, 0.5, 50.0],
                           np.asarray(extra, dtype=float), rng.uniform(0.0, 50.0, n),
                           10.0 ** rng.uniform(-9, 0, n // 4)])


def test_curves_psi_m_dm_ldyn(lib, table_csv):
    rng = np.random.default_rng(20261123)
    D = ctypes.c_double
    for name, kw in curve_cases(table_csv):
        py = make_curve(name, **kw)
        c = c_curve(lib, name, kw)
        knots = getattr(py, "_x", ())
        Is = currents(rng, 3000, extra=knots + tuple(np.nextafter(k, 0.0) for k in knots))
        ref = np.array([py.evaluate(float(I)) for I in Is])
        out = np.empty((len(Is), 4))
        single = np.empty((len(Is), 4))
        p, m, dm, ld = D(), D(), D(), D()
        for j, I in enumerate(Is):
            lib.sm_curve_evaluate(c, I, p, m, dm, ld)
            out[j] = (p.value, m.value, dm.value, ld.value)
            single[j] = (lib.sm_curve_psi(c, I), lib.sm_curve_m(c, I), lib.sm_curve_dm_dI(c, I),
                         lib.sm_curve_L_dyn(c, I))
        ref_single = np.array([(py.psi(float(I)), py.m(float(I)), py.dm_dI(float(I)), py.L_dyn(float(I)))
                               for I in Is])
        for q, what in enumerate(("psi", "m", "dm_dI", "L_dyn")):
            _record(f"{name} {what}", out[:, q], ref[:, q])
            _record(f"{name} {what} (single)", single[:, q], ref_single[:, q])


def test_curves_solve_and_current(lib, table_csv):
    rng = np.random.default_rng(7)
    D = ctypes.c_double
    le = MotorParams().l_e
    for name, kw in curve_cases(table_csv):
        py = make_curve(name, **kw)
        c = c_curve(lib, name, kw)
        n = 1500
        a = np.concatenate([np.zeros(n // 3), np.full(n // 3, le), rng.uniform(0.0, 0.05, n - 2 * (n // 3))])
        cc = np.where(rng.random(n) < 0.1, 10.0 ** rng.uniform(-12, -3, n), rng.uniform(0.0, 2.5, n))
        cc[:5] = (0.0, -1.0, 5e-324, 1e-300, 3.0)
        I, psi = D(), D()
        got, ref = np.empty((n, 2)), np.empty((n, 2))
        for j in range(n):
            assert lib.sm_curve_solve(c, a[j], cc[j], I, psi) == 0
            got[j] = (I.value, psi.value)
            ref[j] = py.solve(float(a[j]), float(cc[j]))
        _record(f"{name} solve I", got[:, 0], ref[:, 0])
        _record(f"{name} solve psi", got[:, 1], ref[:, 1])
        # the inverse and its round trip psi(current(psi)) = psi
        psis = np.concatenate([[0.0, 1e-300, 1e-9], rng.uniform(0.0, 2.0, 1500)])
        inv, back = np.empty(len(psis)), np.empty(len(psis))
        for j, v in enumerate(psis):
            assert lib.sm_curve_current(c, v, I) == 0
            inv[j] = I.value
            back[j] = lib.sm_curve_psi(c, I.value)
        _record(f"{name} current", inv, [py.current(float(v)) for v in psis])
        assert np.allclose(back, psis, rtol=1e-13, atol=1e-300), f"{name}: psi(current(psi)) != psi"


def test_inductance_matrix_and_hypot(lib):
    rng = np.random.default_rng(3)
    D = ctypes.c_double
    Md, Mq, Mdq = D(), D(), D()
    got, ref, h_c, h_py = [], [], [], []
    for _ in range(3000):
        m, dm = rng.uniform(0.01, 0.3), -rng.uniform(0, 0.05)
        i_d, i_q = rng.normal(size=2) * 10.0 ** rng.uniform(-6, 1.5, 2)
        I = math.hypot(i_d, i_q) if rng.random() < 0.9 else 0.0
        lib.sm_inductance_matrix(m, dm, i_d, i_q, I, Md, Mq, Mdq)
        got.append((Md.value, Mq.value, Mdq.value))
        ref.append(inductance_matrix(m, dm, i_d, i_q, I))
        x, y = rng.normal(size=2) * 10.0 ** rng.uniform(-300, 300, 2)
        h_c.append(lib.sm_hypot(x, y))
        h_py.append(math.hypot(x, y))
    _record("inductance_matrix", got, ref)
    _record("hypot (CPython math.hypot)", h_c, h_py)


def motor_cases(table_csv):
    f, _ = table_csv
    return [
        ("default arctan", dict(), 0.0),
        ("arctan B_2", dict(), 0.01),
        ("exponential k=0.8", dict(curve="exponential", L_m0=0.33, L_m_inf=0.01, I_par=3.66, k=0.8,
                                   l_r=4.2e-3, n_p=3), 0.0),
        ("polynomial k=1.3 B_2", dict(curve="polynomial", k=1.3, R_r=0.9, J=0.05, B=0.0), 0.004),
        ("table", dict(curve="table", table_file=str(f)), 0.0),
        ("linear", dict(curve="linear", L_m0=0.1722), 0.0),
        # l_s = 0: the Gamma-equivalent model (the 2.2-kW machine of Qu et al. 2012, its curve exact)
        ("gamma qu2012", dict(l_s=0.0, R_s=3.7, R_r=2.5, l_r=0.023, J=0.015, B=0.0, curve="polynomial",
                              L_m0=0.34, poly_b=0.84**7 / 0.34, poly_n=8), 0.0),
        ("gamma arctan k=0.9 B_2", dict(l_s=0.0, k=0.9), 0.01),
        ("gamma table", dict(l_s=0.0, curve="table", table_file=str(f)), 0.0),
    ]


MOTOR_DEFAULTS = dict(R_s=1.405, R_r=1.395, l_s=5.839e-3, l_r=5.839e-3, k=1.0, n_p=2, J=0.0131, B=2.985e-3,
                      curve="arctan", L_m0=0.2772, L_m_inf=0.01, I_par=3.31, poly_b=2.46, poly_n=7,
                      table_file="",
                      omega_m0=0.0, psi_r0=0.0, h_int=1e-4, B_2=0.0)


def c_motor(lib, values, msg_len=1024):
    v = dict(MOTOR_DEFAULTS)
    v.update(values)
    p, msg = nc.new_motor(lib), ctypes.create_string_buffer(msg_len)
    st = lib.sm_motor_init(p, nc.params(lib, nc.MotorParams, v), nc.params(lib, nc.PlantParams, v), msg,
                           msg_len)
    return st, p, msg.value.decode()


def py_plant(values, B_2):
    v = dict(MOTOR_DEFAULTS)
    v.update(values)
    curve = make_curve(v["curve"], v["L_m0"], v["L_m_inf"], v["I_par"], v["poly_b"], v["poly_n"],
                       v["table_file"])
    params = MotorParams(v["R_s"], v["R_r"], v["l_s"], v["l_r"], v["k"], v["n_p"], v["J"], v["B"], curve)
    return Plant(params, B_2), params


def random_states(rng, n):
    x = np.empty((n, 6))
    x[:, :4] = rng.uniform(-1.6, 1.6, (n, 4))
    x[:, 4] = rng.uniform(-320.0, 320.0, n)
    x[:, 5] = rng.uniform(-10.0, 10.0, n)
    x[:20, :4] = rng.uniform(-1e-9, 1e-9, (20, 4))  # near the unmagnetized origin
    x[0, :4] = 0.0
    u = np.column_stack([rng.uniform(-400, 400, n), rng.uniform(-400, 400, n), rng.uniform(-40, 40, n)])
    return x, u


def _vec(v):
    return (ctypes.c_double * 6)(*v)


def test_plant_derivatives_and_outputs(lib, table_csv):
    rng = np.random.default_rng(11)
    for label, values, B_2 in motor_cases(table_csv):
        st, p, msg = c_motor(lib, dict(values, B_2=B_2))
        assert st == 0, msg
        plant, _ = py_plant(values, B_2)
        x, u = random_states(rng, 2000)
        dx = (ctypes.c_double * 6)()
        o = nc.Outputs()
        got_d, ref_d, got_o, ref_o = [], [], [], []
        for xi, ui in zip(x, u):
            xs = [float(v) for v in xi]
            assert lib.sm_plant_derivatives(p, _vec(xs), *ui, dx) == 0
            got_d.append(list(dx))
            ref_d.append(plant.derivatives(0.0, xs, *map(float, ui)))
            assert lib.sm_plant_outputs_of(p, _vec(xs), ctypes.byref(o)) == 0
            got_o.append([getattr(o, f) for f, _ in nc.Outputs._fields_])
            ref_o.append(list(plant.outputs(xs)))
        got_d, ref_d, got_o, ref_o = map(np.array, (got_d, ref_d, got_o, ref_o))
        # relative to each component's scale over the sample (a derivative can cross zero)
        for j, name in enumerate(("dpsi_s_a", "dpsi_s_b", "dpsi_r_a", "dpsi_r_b", "domega", "dtheta")):
            _record(f"plant {label} derivatives {name}", got_d[:, j], ref_d[:, j])
        for j, (name, _) in enumerate(nc.Outputs._fields_):
            _record(f"plant {label} outputs {name}", got_o[:, j], ref_o[:, j])


def test_plant_rk4_steps(lib, table_csv):
    rng = np.random.default_rng(5)
    for label, values, B_2 in motor_cases(table_csv):
        st, p, msg = c_motor(lib, dict(values, B_2=B_2))
        assert st == 0, msg
        plant, params = py_plant(values, B_2)
        x, u = random_states(rng, 600)
        for n_sub in (1, 3):
            got, ref = [], []
            for xi, ui in zip(x, u):
                xs = [float(v) for v in xi]
                dt = float(rng.uniform(1e-5, 5e-4))
                xc = _vec(xs)
                assert lib.sm_plant_step(p, xc, *ui, dt, n_sub) == 0
                got.append(list(xc))
                ref.append(plant.step(0.0, xs, *map(float, ui), dt, n_sub))
            _record(f"plant {label} rk4 n_sub={n_sub}", got, ref)
        # a trajectory: start-up from the magnetized state, 300 steps of 1 ms in 10 sub-steps
        x0 = initial_state(params, omega_m=3.0, psi_r_alpha=0.8)
        xc = (ctypes.c_double * 6)()
        assert lib.sm_plant_initial_state(p, 3.0, 0.0, 0.8, 0.0, xc) == 0
        _record(f"plant {label} initial_state", list(xc), x0)
        xp, traj_c, traj_p = x0, [], []
        for kstep in range(300):
            va, vb = 300.0 * math.cos(314.0 * kstep * 1e-3), 300.0 * math.sin(314.0 * kstep * 1e-3)
            assert lib.sm_plant_step(p, xc, va, vb, 5.0, 1e-3, 10) == 0
            xp = plant.step(0.0, xp, va, vb, 5.0, 1e-3, 10)
            traj_c.append(list(xc))
            traj_p.append(xp)
        # over 3000 RK4 sub-steps the same floats: the differences do not grow
        _record(f"plant {label} trajectory 300 x 1 ms", traj_c, traj_p)


def test_state_is_a_byte_copy_and_instances_are_independent(lib, table_csv):
    f, _ = table_csv
    st, p, msg = c_motor(lib, dict(curve="table", table_file=str(f)))
    assert st == 0, msg
    st2, other, _ = c_motor(lib, dict(R_s=2.0))
    q = nc.new_motor(lib)
    ctypes.memmove(q, p, ctypes.sizeof(p))
    x1, x2 = _vec([0.3, -0.2, 0.5, 0.1, 50.0, 0.0]), _vec([0.3, -0.2, 0.5, 0.1, 50.0, 0.0])
    assert lib.sm_plant_step(p, x1, 100.0, 0.0, 1.0, 1e-3, 4) == 0
    assert lib.sm_plant_step(other, _vec([0.0] * 6), 100.0, 0.0, 1.0, 1e-3, 4) == 0
    assert lib.sm_plant_step(q, x2, 100.0, 0.0, 1.0, 1e-3, 4) == 0
    assert list(x1) == list(x2)


def test_non_finite_inputs_give_an_error_status(lib):
    st, p, msg = c_motor(lib, {})
    assert st == 0, msg
    nan, inf = float("nan"), float("inf")
    dx = (ctypes.c_double * 6)()
    D = ctypes.c_double
    I, psi = D(), D()
    for name in ("arctan", "exponential", "polynomial", "linear"):
        c = c_curve(lib, name, {})
        for bad in (nan, inf, -inf):
            lib.sm_curve_psi(c, bad), lib.sm_curve_m(c, bad), lib.sm_curve_dm_dI(c, bad)  # no crash
            assert lib.sm_curve_solve(c, 0.01, bad, I, psi) != 0
            assert lib.sm_curve_solve(c, bad, 1.0, I, psi) != 0
            assert lib.sm_curve_current(c, bad, I) != 0
    for k in range(6):
        x = [0.1] * 6
        x[k] = nan
        assert lib.sm_plant_derivatives(p, _vec(x), 0.0, 0.0, 0.0, dx) != 0
        assert lib.sm_plant_outputs_of(p, _vec(x), ctypes.byref(nc.Outputs())) != 0
        xs = _vec(x)
        assert lib.sm_plant_step(p, xs, 0.0, 0.0, 0.0, 1e-4, 1) != 0
    for u in ((nan, 0.0, 0.0), (0.0, inf, 0.0), (0.0, 0.0, -inf)):
        assert lib.sm_plant_derivatives(p, _vec([0.1] * 6), *u, dx) != 0
    xs = _vec([0.1] * 6)
    assert lib.sm_plant_step(p, xs, 0.0, 0.0, 0.0, nan, 1) != 0
    assert lib.sm_plant_step(p, xs, 0.0, 0.0, 0.0, 1e-4, 0) != 0
    # a state that blows up: huge voltage over a long step; x is left as it was
    xs = _vec([0.1] * 6)
    assert lib.sm_plant_step(p, xs, 1e300, 0.0, 0.0, 1e10, 1) != 0
    assert list(xs) == [0.1] * 6
    # the PlantUnit messages
    msg = ctypes.create_string_buffer(512)
    n = ctypes.c_int()
    assert lib.sm_plant_check_step(p, nan, 0.0, 0.0, 1e-3, ctypes.byref(n), msg, 512) != 0
    assert msg.value.decode() == "v_s_alpha = nan: must be a finite number"
    assert lib.sm_plant_check_step(p, 0.0, 0.0, 0.0, -1e-3, ctypes.byref(n), msg, 512) != 0
    assert msg.value.decode() == "communicationStepSize = -0.001: must be a finite number > 0"
    for dt in (1e-3, 1e-4, 2.5e-4, 1.00000001e-4, 3e-5):
        assert lib.sm_plant_check_step(p, 0.0, 0.0, 0.0, dt, ctypes.byref(n), msg, 512) == 0
        assert n.value == max(1, math.ceil(dt / 1e-4 - 1e-9))
    lib.sm_plant_nonfinite_message(0.5, 1e-3, _vec([1.0, nan, inf, -inf, 0.1, 2.0]), msg, 512)
    assert msg.value.decode() == (f"the plant state became non-finite over [0.5, {0.5 + 1e-3}] s: "
                                  f"{(1.0, nan, inf, -inf, 0.1, 2.0)}")


BAD_PARAMETERS = [
    dict(R_s=-1.0), dict(R_s=0.0), dict(R_r=float("nan")), dict(l_s=float("inf")), dict(k=0.0),
    dict(J=float("nan")), dict(J=-0.0131), dict(B=-1.0), dict(n_p=0), dict(L_m_inf=0.5), dict(L_m_inf=0.2772),
    dict(L_m0=-0.1), dict(I_par=float("nan")), dict(I_par=0.0), dict(curve="exponential", I_par=-3.0),
    dict(curve="polynomial", poly_n=1), dict(curve="polynomial", poly_n=0), dict(l_s=-1e-3),
    dict(l_s=float("nan")),
    dict(curve="polynomial", poly_b=-1.0),
    dict(curve="linear", L_m0=0.0), dict(curve="linear", L_m_inf=float("nan")), dict(curve="tanh"),
    dict(curve="table"), dict(curve="table", table_file="/nonexistent/no_load.csv"), dict(psi_r0=-0.1),
    dict(h_int=0.0), dict(omega_m0=float("inf")), dict(B_2=-1.0), dict(B_2=float("nan")),
    dict(l_r=1e-310 * -1),
    dict(L_m_inf=1e-5, L_m0=1e-5), dict(R_s=1e16 * -1.0), dict(R_s=-123456789.125),
]


@pytest.mark.parametrize("bad", BAD_PARAMETERS, ids=lambda d: ",".join(f"{k}={v}" for k, v in d.items()))
def test_bad_parameters_are_rejected_by_name(lib, bad):
    with pytest.raises(ParameterError) as err:
        PlantUnit(dict(MOTOR_DEFAULTS, **bad))
    st, _, msg = c_motor(lib, bad)
    assert st != 0
    e = err.value
    assert msg.startswith(f"{e.field} = ") and repr(e.value) in msg
    assert msg == str(e)


def _write(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


BAD_TABLES = {
    "garbled.csv": "i_mu,psi_m\n1.0,0.27\n2.0,0x1\n3.0,0.68\n",
    "words.csv": "i_mu,psi_m\n1.0,0.27\n2.0,abc # bad\n",
    "three_columns.csv": "1.0,0.27,5\n2.0,0.49,6\n",
    "one_column.csv": "i_mu\n1.0\n",
    "late_header.csv": "1.0,0.27\ni_mu,psi_m\n",
    "empty_cell.csv": "1.0,0.27\n2.0,\n",
    "header_only.csv": "i_mu,psi_m\n# nothing\n\n",
    "empty.csv": "",
    "noisy.csv": ("i_mu,psi_m\n1.0,0.27\n2.0,0.49\n3.0,0.68\n4.0,0.81\n5.0,0.93\n6.0,0.99\n7.0,0.985\n"
                  "8.0,1.10\n"),
    "flat_end.csv": ("i_mu,psi_m\n1.0,0.275\n2.0,0.488\n3.0,0.684\n4.0,0.813\n5.0,0.918\n6.0,0.983\n"
                     "7.0,1.059\n8.0,1.160\n9.1,1.170\n"),
    "repeat.csv": "1.0,0.2\n2.0,0.3\n2.0,0.4\n",
    "negative.csv": "i_mu,psi_m\n-1.0,0.1\n1.0,0.3\n2.0,0.4\n",
    "nan.csv": "i_mu,psi_m\n1.0,nan\n2.0,0.4\n3.0,0.5\n",
    "inf.csv": "i_mu,psi_m\n1.0,0.2\ninf,0.4\n3.0,0.5\n",
    "origin.csv": "0.0,0.1\n1.0,0.3\n2.0,0.4\n",
    "one_point.csv": "1.0,0.2\n",
    "tab_quote.csv": "1.0,0.2\n2.0\t,'x\"\n",
    "underscore.csv": "1.0,0.2\n2_.0,0.3\n",
    "underscore2.csv": "1.0,0.2\n2.0,_0.3\n",
    "underscore3.csv": "1.0,0.2\n2.0,0.3__1\n",
    "unicode_lines.csv": "1.0,0.2\u20282.0,0.3\u0085 \u00a0 3.0,abc\u00a0\n",
}
BAD_BYTES = {  # files Python cannot decode as utf-8-sig: the UnicodeDecodeError text, its positions
    "bad_start.csv": b"i_mu,psi_m\n1.0,0.2 # \xff\n",
    "bad_start_bom.csv": b"\xef\xbb\xbf1.0,0.2\n\x80\n",
    "bad_cont.csv": b"1,2\n\xe2\x28\xa1",
    "bad_cont2.csv": b"1,2\n\xf0\x9f\x28",
    "surrogate.csv": b"1,2\n\xed\xa0\x80",
    "truncated.csv": b"1,2\n\xe2\x82",
    "truncated4.csv": b"# \xf0\x9f\x98",
    "overlong.csv": b"\xc0\x80",
    "too_big.csv": b"\xf4\x90\x80\x80",
    "overlong3.csv": b"\xe0\x80\x80,1",
}


@pytest.mark.parametrize("name", list(BAD_TABLES))
def test_bad_table_files_are_rejected_naming_file_line_and_value(lib, tmp_path, name):
    path = _write(tmp_path, name, BAD_TABLES[name])
    with pytest.raises(ParameterError) as err:
        make_curve("table", table_file=path)
    c, msg = nc.new_curve(lib), ctypes.create_string_buffer(4096)
    st = lib.sm_curve_init(c, b"table", 0.2772, 0.01, 3.31, 2.46, 7, path.encode(), msg, 4096)
    assert st != 0
    text = msg.value.decode()
    assert text == str(err.value)
    assert err.value.field in text and path in text


@pytest.mark.parametrize("name", list(BAD_BYTES) + ["directory", "good_utf8.csv"])
def test_table_files_python_cannot_read(lib, tmp_path, name):
    if name == "directory":
        path = str(tmp_path)
    else:
        path = str(tmp_path / name)
        good = ("# µ-metal, Ψ\u2028\u00a00_1.0e-1,0.2\u3000\u2029 1.0_0 , 0.3 \x85\n2.0,\u20030.3_5\n"
                "3.0,\t0.4\u00a0\n")
        Path(path).write_bytes(BAD_BYTES.get(name, good.encode()))
    c, msg = nc.new_curve(lib), ctypes.create_string_buffer(4096)
    st = lib.sm_curve_init(c, b"table", 0.2772, 0.01, 3.31, 2.46, 7, path.encode(), msg, 4096)
    if name == "good_utf8.csv":
        assert st == 0, msg.value
        py = make_curve("table", table_file=path)
        assert py._x == (0.0, 0.1, 1.0, 2.0, 3.0)
        pts = (0.05, 1.5, 2.5, 4.0)
        assert [lib.sm_curve_psi(c, v) for v in pts] == [py.psi(v) for v in pts]
        return
    with pytest.raises(ParameterError) as err:
        make_curve("table", table_file=path)
    assert st != 0
    assert msg.value.decode() == str(err.value)


def test_table_from_points_matches_table_curve(lib):
    rng = np.random.default_rng(9)
    psi = [0.02 * x + 1.1 * math.tanh(x / 4.0) for x in NO_LOAD]
    x = (ctypes.c_double * len(NO_LOAD))(*NO_LOAD)
    y = (ctypes.c_double * len(NO_LOAD))(*psi)
    c, msg = nc.new_curve(lib), ctypes.create_string_buffer(1024)
    assert lib.sm_curve_init_table(c, x, y, len(NO_LOAD), msg, 1024) == 0, msg.value
    py = TableCurve(NO_LOAD, tuple(psi))
    Is = currents(rng, 2000, extra=NO_LOAD)
    _record("table (points) psi", [lib.sm_curve_psi(c, v) for v in Is], [py.psi(float(v)) for v in Is])
    _record("table (points) dm_dI", [lib.sm_curve_dm_dI(c, v) for v in Is], [py.dm_dI(float(v)) for v in Is])
    # a bad point: the message numbers the points (no file)
    y[4] = y[3]
    with pytest.raises(ParameterError) as err:
        TableCurve(NO_LOAD, tuple(y))
    assert lib.sm_curve_init_table(c, x, y, len(NO_LOAD), msg, 1024) != 0
    assert msg.value.decode() == str(err.value)
    # more points than SM_TABLE_MAX: rejected by name, not overflowed
    big = nc.SM_TABLE_MAX + 5
    xb = (ctypes.c_double * big)(*[0.1 * (k + 1) for k in range(big)])
    yb = (ctypes.c_double * big)(*[math.atan(0.1 * (k + 1)) for k in range(big)])
    assert lib.sm_curve_init_table(c, xb, yb, big, msg, 1024) != 0
    assert msg.value.decode().startswith("i_mu = ")


def test_messages_are_truncated_not_overflowed(lib):
    for n in (1, 2, 5, 17):
        st, _, msg = c_motor(lib, dict(R_s=-1.0), msg_len=n)
        assert st != 0 and len(msg) == n - 1
    buf = ctypes.create_string_buffer(64)
    for v in (0.1, 1e-5, 1e16, 1e15, 123456789.125, -0.0, 5e-324, 1.7976931348623157e308, 2.0, 0.0001):
        assert lib.sm_repr_double(v, buf, 64).decode() == repr(v)


SANITIZED_RUN = textwrap.dedent("""
    import ctypes, math, sys
    sys.path.insert(0, {tests!r})
    import native_core as nc
    lib = nc.declare(ctypes.CDLL({lib!r}))
    msg = ctypes.create_string_buffer(8)
    big = ctypes.create_string_buffer(4096)
    D = ctypes.c_double
    I, psi = D(), D()
    for name in ("arctan", "exponential", "polynomial", "linear", "table", "tanh"):
        for path in ({table!r}, {bad!r}, "/nonexistent.csv", ""):
            c = nc.new_curve(lib)
            st = lib.sm_curve_init(c, name.encode(), 0.2772, 0.01, 3.31, 2.46, 7, path.encode(), msg, 8)
            lib.sm_curve_init(c, name.encode(), 0.2772, 0.01, 3.31, 2.46, 7, path.encode(), big, 4096)
            if st:
                continue
            for v in (0.0, 1e-300, 0.3, 3.0, 17.9, 18.0, 60.0, float("nan"), float("inf"), -1.0):
                lib.sm_curve_evaluate(c, v, I, psi, D(), D())
                lib.sm_curve_solve(c, 0.003, v, I, psi)
                lib.sm_curve_current(c, v, I)
    p = nc.new_motor(lib)
    m = nc.params(lib, nc.MotorParams, dict(curve="table", table_file={table!r}))
    pp = nc.params(lib, nc.PlantParams, dict(psi_r0=0.9, B_2=0.01))
    assert lib.sm_motor_init(p, m, pp, big, 4096) == 0, big.value
    x = (D * 6)(0.5, 0.2, 0.4, 0.1, 10.0, 0.0)
    for k in range(200):
        lib.sm_plant_step(p, x, 300.0 * math.cos(k * 0.3), 300.0 * math.sin(k * 0.3), 5.0, 1e-3, 3)
    lib.sm_plant_step(p, x, float("nan"), 0.0, 0.0, 1e-3, 3)
    lib.sm_plant_outputs_of(p, x, ctypes.byref(nc.Outputs()))
    lib.sm_plant_nonfinite_message(0.0, 1e-3, x, msg, 8)
    # core loss and the thermal model (8 states): the general path, its outputs, its checks
    pe = nc.params(lib, nc.PlantParams, dict(psi_r0=0.9, R_fe=300.0, thermal=1, T_s0=373.15))
    assert lib.sm_motor_init(p, m, pe, big, 4096) == 0, big.value
    x8 = (D * 8)(0.5, 0.2, 0.4, 0.1, 10.0, 0.0, 373.15, 293.15)
    for k in range(200):
        lib.sm_plant_step(p, x8, 300.0 * math.cos(k * 0.3), 300.0 * math.sin(k * 0.3), 5.0, 1e-3, 3)
    lib.sm_plant_outputs_v(p, x8, 300.0, float("nan"), ctypes.byref(nc.Outputs()))
    lib.sm_plant_step(p, x8, float("inf"), 0.0, 0.0, 1e-3, 3)
    for bad in (dict(R_fe=-1.0), dict(C_th_r=0.0), dict(T_s0=-300.0, alpha_s=0.01)):
        assert lib.sm_motor_init(p, m, nc.params(lib, nc.PlantParams, bad), msg, 8) != 0
    m.R_s = -1.0
    assert lib.sm_motor_init(p, m, pp, msg, 8) != 0
    assert lib.sm_motor_init(p, m, None, msg, 8) != 0
    assert lib.sm_motor_init(p, None, pp, msg, 8) != 0
    assert lib.sm_motor_init(None, m, pp, msg, 8) != 0
    xb = (D * 600)(*[0.1 * (k + 1) for k in range(600)])
    lib.sm_curve_init_table(nc.new_curve(lib), xb, xb, 600, msg, 8)
    for path in {bad_files!r}:
        for n in (1, 8, 4096):
            m = ctypes.create_string_buffer(n)
            st = lib.sm_curve_init(nc.new_curve(lib), b"table", 0.2772, 0.01, 3.31, 2.46, 7, path.encode(),
                                   m, n)
            assert st != 0, path
    rb = ctypes.create_string_buffer(40)
    for v in (0.1, -1.0, 1e-5, 1e16, 5e-324, -1.7976931348623157e308, float("nan"), float("-inf"), -0.0):
        lib.sm_repr_double(v, rb, 40)
        lib.sm_repr_double(v, rb, 3)
    print("SANITIZED RUN OK")
""")


def test_under_address_and_undefined_behaviour_sanitizers(tmp_path, table_csv):
    gcc = shutil.which("gcc")
    asan = subprocess.run([gcc, "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    if not os.path.isabs(asan) or not os.path.exists(asan):
        pytest.skip("no libasan runtime")
    lib = nc.build(nc.SANITIZE, tmp_path)
    bad = _write(tmp_path, "garbled.csv", BAD_TABLES["garbled.csv"] + "x" * 5000 + "\n")
    bad_files = [_write(tmp_path, name, text) for name, text in BAD_TABLES.items()]
    bad_files.append(_write(tmp_path, "long_line.csv", "1.0,0.2\n" + "9" * 5000 + ",1.0\n"))
    rows = "".join(f"{0.1 * (k + 1)!r},{math.atan(0.1 * (k + 1))!r}\n" for k in range(600))
    bad_files.append(_write(tmp_path, "too_many.csv", rows))
    bad_files.append(_write(tmp_path, "nul.csv", "1.0,0.2\x00\n2.0,0.3\n"))
    script = tmp_path / "run.py"
    script.write_text(SANITIZED_RUN.format(tests=str(Path(__file__).parent), lib=str(lib),
                                           table=str(table_csv[0]), bad=bad, bad_files=bad_files))
    env = dict(os.environ, LD_PRELOAD=asan, ASAN_OPTIONS="detect_leaks=0:abort_on_error=0:exitcode=99",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:exitcode=98")
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=120)
    report = res.stdout + res.stderr
    assert res.returncode == 0 and "SANITIZED RUN OK" in res.stdout, report[:4000]
    assert "AddressSanitizer" not in report and "runtime error" not in report, report[:4000]


def _residual_ok(py, a, c, I, psi):
    """``a I + psi(I) = c`` holds at the root to a few ulps of c (the curve evaluated anew)."""
    eps, p = np.finfo(float).eps, py.psi(I)
    return abs(a * I + p - c) <= 8 * eps * c and abs(psi - p) <= 8 * eps * p


def test_warm_started_solve_is_bit_identical_in_c_and_agrees_with_the_cold_root(lib, table_csv):
    """curve.solve(a, c, guess) and sm_curve_solve_from: the same floats for every guess (above and below
    the root, below the lower bound, 0, NaN, inf); the warm root solves the equation as the cold one
    does (residual checked by evaluating the curve anew) and differs from it by no more than the
    equation's own rounding allows: a few ulps of c divided by the slope a + L_dyn(I)."""
    rng = np.random.default_rng(2026)
    D = ctypes.c_double
    le = MotorParams().l_e
    for name, kw in curve_cases(table_csv):
        py = make_curve(name, **kw)
        c = c_curve(lib, name, kw)
        I, psi = D(), D()
        got, ref, spread = [], [], 0
        for _ in range(400):
            a = float(rng.choice([0.0, le, rng.uniform(0.0, 0.05)]))
            cc = float(rng.uniform(1e-6, 2.5))
            cold = py.solve(a, cc)
            for guess in (cold[0] * (1 + rng.uniform(-0.05, 0.05)), cold[0] * (1 + rng.uniform(-1e-6, 1e-6)),
                          cold[0], 2.0 * cold[0] + 1.0, 1e-9, 0.0, math.nan, math.inf):
                assert lib.sm_curve_solve_from(c, a, cc, guess, I, psi) == 0
                warm = py.solve(a, cc, guess)
                got.append((I.value, psi.value))
                ref.append(warm)
                assert _residual_ok(py, a, cc, *warm), (name, a, cc, guess, warm)
                bound = 8 * np.finfo(float).eps * cc / (a + py.L_dyn(cold[0]))
                spread = max(spread, abs(warm[0] - cold[0]) / bound)
        assert got == ref, f"{name}: C and Python warm starts differ"
        print(f"{name}: warm root within {spread:.3g} of the rounding bound of the cold one")
        assert spread <= 1, f"{name}: a warm root {spread:.3g} times the rounding bound from the cold one"


def test_plant_step_warm_stages_agree_with_cold_rk4_and_depend_on_the_step_only(lib, table_csv):
    """Plant.step warm-starts the solves of RK4 stages 2-4: against the all-cold RK4 of the same
    derivatives (integrate.rk4 without the warm list) the state differs by rounding only; a step of
    n h in n sub-steps is n steps of h to the last bit (each sub-step starts cold); C is the same."""
    from satmotor.machine.integrate import rk4

    rng = np.random.default_rng(3)
    for label, values, B_2 in motor_cases(table_csv):
        plant, _ = py_plant(values, B_2)
        x, u = random_states(rng, 200)
        worst = 0.0
        for xi, ui in zip(x, u):
            xs, ui = [float(v) for v in xi], tuple(map(float, ui))
            warm = plant.step(0.0, xs, *ui, 1e-4, 1)
            cold = rk4(plant.derivatives, 0.0, xs, 1e-4, 1, ui)
            scale = max(1.0, max(abs(v) for v in cold))
            worst = max(worst, max(abs(p - q) for p, q in zip(warm, cold)) / scale)
            two = plant.step(0.0, plant.step(0.0, xs, *ui, 1e-4, 1), *ui, 1e-4, 1)
            assert plant.step(0.0, xs, *ui, 2e-4, 2) == two
        assert worst <= 1e-13, f"{label}: warm and cold RK4 differ by {worst:.3g}"


def test_solve_memo_changes_no_result(lib, table_csv):
    """The C plant's memo of the last cold solve (the FMU keeps the outputs' solve for the next step):
    stepping with an empty, a matching, a stale (another state's) or a copied memo gives the floats of
    the step without one, bit for bit, and the outputs read through it are those without one."""
    rng = np.random.default_rng(17)
    for label, values, B_2 in motor_cases(table_csv):
        st, p, msg = c_motor(lib, dict(values, B_2=B_2))
        assert st == 0, msg
        memo = (ctypes.c_double * 4)()
        lib.sm_solve_memo_clear(memo)
        assert all(math.isnan(v) for v in memo)
        x, u = random_states(rng, 150)
        for j, (xi, ui) in enumerate(zip(x, u)):
            xs = [float(v) for v in xi]
            plain, with_memo = _vec(xs), _vec(xs)
            o_plain, o_memo = nc.Outputs(), nc.Outputs()
            if j % 3 == 0:  # matching: the outputs at this state filled it
                assert lib.sm_plant_outputs_memo(p, memo, _vec(xs), 0.0, 0.0, ctypes.byref(o_memo)) == 0
                assert lib.sm_plant_outputs_of(p, _vec(xs), ctypes.byref(o_plain)) == 0
                assert bytes(o_memo) == bytes(o_plain)
                assert (memo[2], memo[3]) == (o_plain.i_mu, o_plain.psi_m)  # kept: (a, c, I, psi)
            elif j % 3 == 1:  # stale: another state's root, or a forged one for this (a, c) is never asked
                lib.sm_plant_outputs_memo(p, memo, _vec([float(v) for v in x[j - 1]]), 0.0, 0.0,
                                          ctypes.byref(o_memo))
            assert lib.sm_plant_step(p, plain, *ui, 1e-4, 2) == 0
            assert lib.sm_plant_step_memo(p, memo, with_memo, *ui, 1e-4, 2) == 0
            assert list(plain) == list(with_memo), f"{label}: the memo changed a step"

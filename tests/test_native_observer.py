"""The rotor-flux observer in C (fmu/native/core/sm_observer.c) against satmotor.estimation.observer,
sample by sample over random input sequences, every curve family: the Python is the specification."""

import ctypes

import numpy as np
import pytest
from conftest import CURVES
from native_core import build, declare

from satmotor.estimation.observer import RotorFluxObserver
from satmotor.machine.params import MotorParams

D = ctypes.c_double


@pytest.fixture(scope="module")
def lib():
    return declare(ctypes.CDLL(str(build())))  # the signatures read from the headers


def _curve(lib, curve):
    buf = ctypes.create_string_buffer(lib.sm_curve_size())
    msg = ctypes.create_string_buffer(256)
    table = b""
    if curve.name == "table":
        pytest.skip("table curve: covered by the curve tests; the observer only calls solve")
    args = [getattr(curve, n, d) for n, d in (("L_m0", 0.2772), ("L_m_inf", 0.01), ("I_par", 3.31),
                                              ("poly_b", 2.46))]
    assert lib.sm_curve_init(buf, curve.name.encode(), *args, int(getattr(curve, "poly_n", 7)), table, msg,
                             256) == 0, msg.value
    return buf


@pytest.mark.parametrize("name", [n for n in CURVES if n != "table"])
@pytest.mark.parametrize("n_sub, Ts", [(1, 1e-4), (3, 2.5e-4)])
def test_c_observer_matches_python_sample_by_sample(lib, name, n_sub, Ts):
    p = MotorParams(curve=CURVES[name])
    py = RotorFluxObserver(p, Ts, n_sub)
    curve = _curve(lib, p.curve)
    obs = ctypes.create_string_buffer(lib.sm_observer_size())
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_observer_init(obs, p.R_r, p.l_r, p.k, p.n_p, Ts, n_sub, msg, 256) == 0, msg.value
    py.reset(0.3, -0.1)
    assert lib.sm_observer_reset(obs, 0.3, -0.1, msg, 256) == 0
    rng = np.random.default_rng(11)
    pa, pb = D(), D()
    worst = 0.0
    t = 0.0
    for _ in range(2000):
        t += Ts
        i_a, i_b = 8.0 * np.cos(300 * t) + rng.normal(0, 0.5), 8.0 * np.sin(300 * t) + rng.normal(0, 0.5)
        w = 120.0 * np.sin(3 * t) + rng.normal(0, 1.0)
        want = py.update(float(i_a), float(i_b), float(w))
        assert lib.sm_observer_update(obs, curve, i_a, i_b, w, ctypes.byref(pa), ctypes.byref(pb)) == 0
        scale = max(abs(want[0]) + abs(want[1]), 1e-3)
        worst = max(worst, abs(pa.value - want[0]) / scale, abs(pb.value - want[1]) / scale)
    print(f"{name} n_sub {n_sub}: worst relative difference {worst:.3g}")
    assert worst <= 1e-12


@pytest.mark.parametrize("args, field", [((1.395, 5.839e-3, 1.0, 2, 0.0, 1), "Ts"),
                                         ((1.395, 5.839e-3, 1.0, 2, 1e-4, 0), "n_sub"),
                                         ((float("nan"), 5.839e-3, 1.0, 2, 1e-4, 1), "R_r")])
def test_c_observer_refuses_bad_arguments_by_name(lib, args, field):
    obs = ctypes.create_string_buffer(lib.sm_observer_size())
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_observer_init(obs, *args, msg, 256) != 0
    assert msg.value.decode().startswith(f"{field} = ")

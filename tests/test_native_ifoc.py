"""The IFOC PI baseline in C (fmu/native/core/sm_ifoc.c) against satmotor.control.ifoc, sample by sample:
the Python is the specification."""

import ctypes
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from native_core import STRUCTS, declare

from satmotor.control.ifoc import IFOCController, IFOCGains
from satmotor.machine.params import MotorParams, RatedData

ROOT = Path(__file__).resolve().parents[1]
FLAGS = ["-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion",
         "-Wshadow"]


Gains, Diag = STRUCTS["sm_ifoc_gains"], STRUCTS["sm_ifoc_diagnostics"]  # read from the headers


@pytest.fixture(scope="module", params=["plain", "sanitized"])
def lib(request, tmp_path_factory):
    out = tmp_path_factory.mktemp("ifoc") / "libifoc.so"
    extra = ["-fsanitize=undefined", "-fno-sanitize-recover=all"] if request.param == "sanitized" else []
    subprocess.run(["gcc", *FLAGS, *extra, str(ROOT / "fmu/native/core/sm_ifoc.c"), "-o", str(out), "-lm"],
                   check=True)
    return declare(ctypes.CDLL(str(out)))  # the signatures read from the headers


def _c_ifoc(lib, p, g, Ts, L_m):
    buf = ctypes.create_string_buffer(4096)  # larger than sizeof(sm_ifoc)
    msg = ctypes.create_string_buffer(256)
    status = lib.sm_ifoc_init(buf, p.R_s, p.R_r, p.l_s, p.l_r, p.k, p.n_p, p.J,
                              ctypes.byref(Gains(g.w_c, g.w_speed, g.I_max, g.V_dc)), Ts, L_m, msg, 256)
    return buf, status, msg.value.decode()


CASES = [(MotorParams(), IFOCGains(), 1e-4),
         (MotorParams(k=0.9, l_r=5.839e-3 * 0.81, R_r=1.395 * 0.81, n_p=3), IFOCGains(w_c=1500.0, I_max=8.0),
          2e-4)]


@pytest.mark.parametrize("p, g, Ts", CASES)
def test_c_ifoc_matches_python_sample_by_sample(lib, p, g, Ts):
    L_m = p.curve.m(RatedData().I_mu_n)
    py = IFOCController(p, g, Ts, L_m)
    buf, status, msg = _c_ifoc(lib, p, g, Ts, L_m)
    assert status == 0, msg
    rng = np.random.default_rng(5)
    theta0, phi0 = 2.7, 0.8
    py.reset(theta0, phi0)
    assert lib.sm_ifoc_reset(buf, theta0, phi0, None, 0) == 0
    va, vb, diag = ctypes.c_double(), ctypes.c_double(), Diag()
    worst = 0.0
    limited = {"voltage": 0, "current": 0}
    for k in range(3000):
        big = k % 500 < 40  # bursts of large errors: both limits and the anti-windup branches
        i_a, i_b = rng.normal(0.0, 30.0 if big else 6.0, 2)
        w = rng.uniform(-150.0, 150.0)
        w_ref = w + rng.normal(0.0, 200.0 if big else 5.0)
        phi_ref = rng.uniform(0.3, 1.2)
        pa, pb, pd = py(float(i_a), float(i_b), float(w), float(w_ref), float(phi_ref))
        assert lib.sm_ifoc_step(buf, i_a, i_b, w, w_ref, phi_ref, ctypes.byref(va), ctypes.byref(vb),
                                ctypes.byref(diag), None, 0) == 0
        got = (va.value, vb.value) + tuple(getattr(diag, f) for f, _ in Diag._fields_[:10])
        want = (pa, pb) + tuple(pd[:10])
        worst = max(worst, max(abs(a - b) / max(abs(b), 1e-12) for a, b in zip(got, want)))
        assert (diag.voltage_limited, diag.current_limited) == (pd.voltage_limited, pd.current_limited)
        limited["voltage"] += pd.voltage_limited
        limited["current"] += pd.current_limited
    print(f"worst relative difference {worst:.3g}, limited samples {limited}")
    assert worst <= 1e-12
    assert limited["voltage"] > 0 and limited["current"] > 0  # the limit branches were exercised


@pytest.mark.parametrize("field, change", [("R_s", dict(R_s=-1.0)), ("J", dict(J=math.nan)),
                                           ("w_c", dict(w_c=2e4)), ("w_speed", dict(w_speed=5000.0)),
                                           ("I_max", dict(I_max=0.0))])
def test_c_ifoc_refuses_what_python_refuses_naming_the_field(lib, field, change):
    p_kw = {k: v for k, v in change.items() if k in ("R_s", "J")}
    g_kw = {k: v for k, v in change.items() if k not in p_kw}
    p = MotorParams.__new__(MotorParams)  # bypass the dataclass checks: the C must make its own
    object.__setattr__(p, "__dict__", {**MotorParams().__dict__, **p_kw})
    g = IFOCGains.__new__(IFOCGains)
    object.__setattr__(g, "__dict__", {**IFOCGains().__dict__, **g_kw})
    _, status, msg = _c_ifoc(lib, p, g, 1e-4, 0.17)
    assert status != 0 and msg.startswith(f"{field} = "), msg


def test_c_ifoc_refuses_a_bad_flux_reference_and_changes_nothing(lib):
    p, g = MotorParams(), IFOCGains()
    buf, status, _ = _c_ifoc(lib, p, g, 1e-4, 0.17)
    before = bytes(buf)
    msg = ctypes.create_string_buffer(256)
    va, vb = ctypes.c_double(), ctypes.c_double()
    for bad in (0.0, -0.5, math.nan, math.inf):
        assert lib.sm_ifoc_step(buf, 1.0, 0.0, 0.0, 0.0, bad, ctypes.byref(va), ctypes.byref(vb), None, msg,
                                256) != 0
        assert msg.value.decode().startswith("psi_ref_shaped = ")
    assert bytes(buf) == before


def test_c_set_inductance_equals_the_python_and_refuses_a_bad_one(lib):
    """IFOCController.set_inductance and sm_ifoc_set_inductance: the loops designed again for another L_m
    (the drive's switch), then the same samples as a controller built with that L_m from the start."""
    p, g, Ts = MotorParams(), IFOCGains(), 1e-4
    py = IFOCController(p, g, Ts, p.curve.m(RatedData().I_mu_n))
    buf, status, msg = _c_ifoc(lib, p, g, Ts, p.curve.m(RatedData().I_mu_n))
    assert status == 0, msg
    L_m = 0.95 / p.curve.current(0.95)
    py.set_inductance(L_m)
    assert lib.sm_ifoc_set_inductance(buf, L_m, None, 0) == 0
    fresh = IFOCController(p, g, Ts, L_m)
    assert (py.sigL, py.R_eq, py.tau_r, py.Kp_i, py.Ki_i) == (fresh.sigL, fresh.R_eq, fresh.tau_r, fresh.Kp_i,
                                                              fresh.Ki_i)
    for c in (py, fresh):
        c.reset(0.3, 0.9)
    assert lib.sm_ifoc_reset(buf, 0.3, 0.9, None, 0) == 0
    va, vb = ctypes.c_double(), ctypes.c_double()
    rng = np.random.default_rng(11)
    for _ in range(500):
        i_a, i_b = (float(v) for v in rng.normal(0.0, 8.0, 2))
        w = float(rng.uniform(-100.0, 100.0))
        a, b = py(i_a, i_b, w, w + 3.0, 0.95), fresh(i_a, i_b, w, w + 3.0, 0.95)
        assert a[:2] == b[:2]
        assert lib.sm_ifoc_step(buf, i_a, i_b, w, w + 3.0, 0.95, ctypes.byref(va), ctypes.byref(vb), None,
                                None, 0) == 0
        assert va.value == pytest.approx(a[0], rel=1e-12, abs=1e-12)
        assert vb.value == pytest.approx(a[1], rel=1e-12, abs=1e-12)
    before = bytes(buf)
    err = ctypes.create_string_buffer(256)
    for bad in (0.0, -0.1, math.nan, math.inf):
        assert lib.sm_ifoc_set_inductance(buf, bad, err, 256) != 0
        assert err.value.decode().startswith("L_m = ")
        with pytest.raises(ValueError, match="L_m"):
            py.set_inductance(bad)
    assert bytes(buf) == before

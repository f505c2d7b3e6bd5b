"""The native C control law (fmu/native/core/sm_law.c, sm_references.c) against the Python package.

Function-level comparison on thousands of seeded random states: the control model's vector fields,
the magnetizing state from measurements, the backstepping error system and the control step (every
curve family, k != 1, both load modes, integral states, the current limit on both sides, the
stator-flux option, the singularity guard, the voltage limit), and the reference shaper.  The C
code keeps the Python's formulas and their order, so the results are expected to be the same
floats; the bound is 1e-12 relative and the worst difference per function is printed (-s).
"""

from __future__ import annotations

import ctypes
import math
import os
import random
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from native_core import SANITIZE, STRUCTS, build, load, new_motor, params
from native_core import MotorParams as CMotorParams

from satmotor.control.backstepping import BacksteppingGains, ControllerConfig, control, error_system
from satmotor.control.fo_model import ModelConstants, flux_rate, to_stationary, vector_fields
from satmotor.control.measurements import from_magnetizing_current, from_rotor_flux, from_stator_flux
from satmotor.control.modulation import limit_voltage
from satmotor.control.references import RISE_TIME_PRODUCT, ReferenceShaper, transition_matrix
from satmotor.errors import ParameterError
from satmotor.machine.params import MotorParams, make_curve
from satmotor.machine.plant import Plant

REL = 1e-12
D = ctypes.c_double
CURVES = ("arctan", "exponential", "polynomial", "table", "linear")


# the structs read from the headers (native_core.STRUCTS), and the names of their members in order
Gains, LawConfig, ModelConsts = STRUCTS["sm_gains"], STRUCTS["sm_law_config"], STRUCTS["sm_model_constants"]
Fields, Magnetizing, ErrorState = STRUCTS["sm_fields"], STRUCTS["sm_magnetizing"], STRUCTS["sm_error_state"]
ControlOut, Shaper = STRUCTS["sm_control_output"], STRUCTS["sm_shaper"]
FIELD_NAMES = tuple(n for n, _ in Fields._fields_)
MAG_NAMES = tuple(n for n, _ in Magnetizing._fields_)
OUT_NAMES = tuple(n for n, _ in ControlOut._fields_)
OUT_FLAGS = tuple(n for n, t in ControlOut._fields_ if t is ctypes.c_int)


# --------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def lib():
    return load()  # the signatures read from the headers


def arr(values):
    return (D * len(values))(*values)


class Worst:
    """Largest relative difference seen per quantity (0 for equal floats, NaN == NaN)."""

    def __init__(self, name):
        self.name, self.worst, self.where, self.n = name, 0.0, None, 0

    def check(self, label, c, p, ctx):
        self.n += 1
        c, p = float(c), float(p)
        if c == p or (c != c and p != p):
            return
        d = abs(c - p) / max(abs(c), abs(p))
        if not d <= REL:
            raise AssertionError(f"{self.name} {label}: C {c!r} vs Python {p!r} (rel {d:.3g}) at {ctx}")
        if d > self.worst:
            self.worst, self.where = d, (label, ctx)

    def report(self):
        print(f"\n[native law] {self.name}: {self.n} values, worst relative difference {self.worst:.3g}"
              + (f" ({self.where[0]})" if self.where else ""))


# ------------------------------------------------------------------------- motors, one per variant


def table_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("curve") / "curve.csv"
    c = make_curve("arctan")
    lines = ["i_mu,psi_m"] + [f"{x!r},{c.psi(x)!r}" for x in [0.5 * i for i in range(1, 41)]]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.fixture(scope="module")
def motors(lib, tmp_path_factory):
    """(MotorParams, C sm_motor buffer) for every curve family, k = 1 and k != 1."""
    tf = table_file(tmp_path_factory)
    out = []
    rng = random.Random(7)
    for name in CURVES:
        for k, gamma in ((1.0, False), (0.83, False), (1.0, True)):  # gamma: l_s = 0, the Gamma model
            R_s, R_r = 1.405 * rng.uniform(0.7, 1.3), 1.395 * rng.uniform(0.7, 1.3)
            l_s, l_r = 5.839e-3 * rng.uniform(0.7, 1.3), 5.839e-3 * rng.uniform(0.7, 1.3)
            n_p, J, B = rng.choice((1, 2, 3)), 0.0131 * rng.uniform(0.5, 2.0), 2.985e-3
            L_m0, L_m_inf, I_par, poly_b, poly_n = 0.2772, 0.01, 3.31, 2.46, 7
            if name == "exponential":
                L_m0, I_par = 0.330, 3.66
            if gamma:
                l_s, l_r = 0.0, 2.0 * l_r
                if name == "polynomial":  # Qu et al. 2012: even exponent
                    L_m0, poly_b, poly_n = 0.34, 0.84**7 / 0.34, 8
            curve = make_curve(name, L_m0, L_m_inf, I_par, poly_b, poly_n, tf if name == "table" else "")
            p = MotorParams(R_s, R_r, l_s, l_r, k, n_p, J, B, curve)
            buf = new_motor(lib)
            msg = ctypes.create_string_buffer(256)
            m = params(lib, CMotorParams, dict(
                R_s=R_s, R_r=R_r, l_s=l_s, l_r=l_r, k=k, n_p=n_p, J=J, B=B, curve=name, L_m0=L_m0,
                L_m_inf=L_m_inf, I_par=I_par, poly_b=poly_b, poly_n=poly_n,
                table_file=tf if name == "table" else ""))
            st = lib.sm_motor_init(buf, m, None, msg, 256)
            assert st == 0, msg.value
            out.append((f"{name}, k={k}" + (", l_s=0" if gamma else ""), p, buf))
    return out


# ------------------------------------------------------------------------------- control model


def test_model_constants_and_vector_fields(lib, motors):
    rng = random.Random(11)
    wc, wf = Worst("ModelConstants.of"), Worst("vector_fields")
    for label, p, buf in motors:
        c = ModelConstants.of(p)
        cc = ModelConsts()
        lib.sm_model_constants_of(buf, ctypes.byref(cc))
        for name in ModelConstants._fields:
            wc.check(name, getattr(cc, name), getattr(c, name), label)
        for _ in range(400):
            phi = rng.choice((rng.uniform(0.0, 1.3), rng.uniform(0.0, 0.05)))
            imd, imq = rng.uniform(-15, 15), rng.uniform(-30, 30)
            if rng.random() < 0.05:
                imq = 0.0
            I = math.hypot(imd, imq)
            _, m, dm, _ = p.curve.evaluate(I)
            if rng.random() < 0.3:  # m measured: need not be the curve's
                m *= rng.uniform(0.8, 1.2)
            w, theta = rng.uniform(-400, 400), rng.uniform(-3000, 3000)
            phi_ws = max(phi, rng.uniform(0.01, 0.1))
            args = (phi, imd, imq, w, m, dm, I, theta, phi_ws)
            py = vector_fields(c, *args)
            f = Fields()
            lib.sm_vector_fields(ctypes.byref(cc), *args, ctypes.byref(f))
            for name, v in zip(FIELD_NAMES, py):
                wf.check(name, getattr(f, name), v, (label, args))
            wf.check("flux_rate", lib.sm_flux_rate(c.a, c.k, phi, imd, m), flux_rate(c.a, c.k, phi, imd, m),
                     args)
    wc.report()
    wf.report()


# ------------------------------------------------------------------------------ measurements


def random_meas(rng, phi_max=1.3):
    """(i_s_a, i_s_b, psi_r_a, psi_r_b, psi_s_a, psi_s_b, omega_m)"""
    phi = rng.choice((rng.uniform(0.0, phi_max), rng.uniform(0.0, 0.06), 0.0))
    ang = rng.uniform(-math.pi, math.pi)
    isa, isb = rng.uniform(-25, 25), rng.uniform(-25, 25)
    if rng.random() < 0.03:
        isa = isb = 0.0
    w = rng.uniform(-400, 400)  # drawn in this order: the samples of the earlier layout
    psa, psb = rng.uniform(-1.3, 1.3), rng.uniform(-1.3, 1.3)
    return (isa, isb, phi * math.cos(ang), phi * math.sin(ang), psa, psb, w)


def test_magnetizing_state(lib, motors):
    rng = random.Random(12)
    wr, ws, wm = Worst("from_rotor_flux"), Worst("from_stator_flux"), Worst("from_magnetizing_current")
    for label, p, buf in motors:
        for _ in range(300):
            mm = random_meas(rng)
            c = Magnetizing()
            assert lib.sm_from_rotor_flux(*mm[:4], buf, ctypes.byref(c)) == 0
            for name, v in zip(MAG_NAMES, from_rotor_flux(*mm[:4], p)):
                wr.check(name, getattr(c, name), v, (label, mm))
            assert lib.sm_from_stator_flux(*mm[:4], *mm[4:6], buf, ctypes.byref(c)) == 0
            for name, v in zip(MAG_NAMES, from_stator_flux(*mm[:4], *mm[4:6], p)):
                ws.check(name, getattr(c, name), v, (label, mm))
            assert lib.sm_from_magnetizing_current(*mm[:4], buf, ctypes.byref(c)) == 0
            for name, v in zip(MAG_NAMES, from_magnetizing_current(*mm[:4], p)):
                wm.check(name, getattr(c, name), v, (label, mm))
    for w in (wr, ws, wm):
        w.report()


# --------------------------------------------------------------------------- the error system


def random_gains(rng):
    g = BacksteppingGains(rng.uniform(50, 400), rng.uniform(300, 3000), rng.uniform(30, 300),
                          rng.uniform(100, 1500), rng.choice((0.0, rng.uniform(0, 5e3))),
                          rng.choice((0.0, rng.uniform(0, 3e3))))
    return g, Gains(g.c1, g.c2, g.d1, g.d2, g.c0, g.d0)


def random_ref(rng):
    return (rng.choice((rng.uniform(0.0, 1.2), 0.9)), rng.uniform(-50, 50), rng.uniform(-5e3, 5e3),
            rng.uniform(-300, 300), rng.uniform(-3e3, 3e3), rng.uniform(-1e5, 1e5))


def random_i_max(rng):
    """No limit, a limit that rarely binds, or one that often binds (flux side and torque side)."""
    return rng.choice((math.inf, rng.uniform(20, 60), rng.uniform(1, 12), rng.uniform(3, 6)))


ES_SCALARS = ("e1", "e2", "z1", "z2", "dt_e2", "dt_z2", "beta1", "beta2", "W", "omega_s", "theta_dot")


def compare_error_system(w, c, py, ctx):
    for name in ES_SCALARS:
        w.check(name, getattr(c, name), getattr(py, name), ctx)
    for i in range(4):
        w.check(f"grad_e2[{i}]", c.grad_e2[i], py.grad_e2[i], ctx)
        w.check(f"grad_z2[{i}]", c.grad_z2[i], py.grad_z2[i], ctx)
    for i in range(2):
        for j in range(2):
            w.check(f"Lambda[{i}][{j}]", c.Lambda[i][j], py.Lambda[i][j], ctx)
    assert bool(c.singular_limited) == py.singular_limited, ctx
    assert c.flux_limited == py.flux_limited, ctx
    assert c.torque_limited == py.torque_limited, ctx


def test_error_system(lib, motors):
    rng = random.Random(13)
    w = Worst("error_system")
    seen = {"d+": 0, "d-": 0, "q+": 0, "q-": 0, "singular": 0, "adapt": 0}
    for label, p, buf in motors:
        for _ in range(800):
            g, cg = random_gains(rng)
            phi = rng.choice((rng.uniform(0.0, 1.3), rng.uniform(0.0, 0.06), 0.0))
            x = (phi, rng.uniform(-12, 15), rng.uniform(-30, 30), rng.uniform(-400, 400))
            ref = random_ref(rng)
            theta, theta_dot = rng.uniform(-3e3, 3e3), rng.uniform(-1e4, 1e4)
            phi_min = rng.choice((0.05, rng.uniform(0.01, 0.2)))
            tm = rng.uniform(100, 1e4)
            adapt = rng.choice((None, (rng.uniform(1, 100), tm)))
            if adapt is not None and rng.random() < 0.2:
                theta = rng.choice((tm, -tm))  # at the projection bound
            integ = rng.choice(((0.0, 0.0), (rng.uniform(-0.01, 0.01), rng.uniform(-1, 1))))
            i_max = random_i_max(rng)
            py = error_system(x, ref, p, g, theta, theta_dot, phi_min, adapt, integ, i_max)
            c = ErrorState()
            st = lib.sm_error_system(arr(x), arr(ref), buf, ctypes.byref(cg), theta, theta_dot, phi_min,
                                     None if adapt is None else arr(adapt), arr(integ), i_max,
                                     ctypes.byref(c))
            assert st == 0
            compare_error_system(w, c, py, (label, x, ref, theta, theta_dot, phi_min, adapt, integ, i_max))
            seen["d+"] += py.flux_limited == 1
            seen["d-"] += py.flux_limited == -1
            seen["q+"] += py.torque_limited == 1
            seen["q-"] += py.torque_limited == -1
            seen["singular"] += py.singular_limited
            seen["adapt"] += adapt is not None
    w.report()
    print(f"[native law] error_system cases: {seen}")
    assert min(seen.values()) >= 50, seen


# ------------------------------------------------------------------------------------ control


def test_control(lib, motors):
    rng = random.Random(14)
    w = Worst("control")
    seen = {"vlim": 0, "singular": 0, "current": 0, "stator_flux": 0, "estimated": 0, "e0_held": 0,
            "z0_held": 0, "phi0": 0, "plain": 0}
    for label, p, buf in motors:
        for _ in range(800):
            g, cg = random_gains(rng)
            cfg = ControllerConfig(V_dc=rng.choice((540.0, rng.uniform(50, 2000), 1e6)),
                                   Ts=rng.choice((0.0, 1e-4, rng.uniform(1e-5, 5e-4))),
                                   phi_min=rng.choice((0.05, rng.uniform(0.01, 0.2))),
                                   load_mode=rng.choice(("known", "estimated")),
                                   g_theta=rng.uniform(1, 100), theta_max=rng.uniform(100, 1e4),
                                   use_stator_flux=rng.random() < 0.3)
            ccfg = LawConfig(cfg.V_dc, cfg.Ts, cfg.phi_min, cfg.load_mode == "estimated", cfg.g_theta,
                             cfg.theta_max, cfg.use_stator_flux)
            meas = random_meas(rng)
            ref = random_ref(rng)
            load = (rng.uniform(-30, 30), rng.uniform(-1e3, 1e3))
            theta_hat = rng.uniform(-1.5, 1.5) * cfg.theta_max
            integ = rng.choice(((0.0, 0.0), (rng.uniform(-0.01, 0.01), rng.uniform(-1, 1))))
            i_max = random_i_max(rng)
            py = control(meas, ref, load, p, g, cfg, theta_hat, integ, i_max)
            c = ControlOut()
            st = lib.sm_control(arr(meas), arr(ref), arr(load), buf, ctypes.byref(cg), ctypes.byref(ccfg),
                                theta_hat, arr(integ), i_max, ctypes.byref(c))
            assert st == 0
            ctx = (label, meas, ref, load, theta_hat, integ, i_max, cfg, g)
            for name, v in zip(OUT_NAMES, py):
                if name in OUT_FLAGS:
                    assert bool(getattr(c, name)) == v, (name, ctx)
                else:
                    w.check(name, getattr(c, name), v, ctx)
            seen["vlim"] += py.voltage_limited
            seen["singular"] += py.singular_limited
            seen["current"] += py.current_limited
            seen["stator_flux"] += cfg.use_stator_flux
            seen["estimated"] += cfg.load_mode == "estimated"
            seen["e0_held"] += py.e0_dot == 0.0 and py.e1 != 0.0
            seen["z0_held"] += py.z0_dot == 0.0 and py.z1 != 0.0
            seen["phi0"] += py.Phi_rd == 0.0
            seen["plain"] += not (py.voltage_limited or py.singular_limited or py.current_limited)
    w.report()
    print(f"[native law] control cases: {seen}")
    assert min(seen.values()) >= 50, seen


def test_voltage_limit_random_vectors(lib):
    """sm_voltage_limit against modulation.limit_voltage, both modes, at random commands (inside and
    outside the circle and the hexagon, huge, infinite, NaN) in random frames: the same floats."""
    rng = random.Random(35)
    seen = {"lin": 0, "over": 0, "between": 0, "nonfinite": 0}
    for _ in range(20000):
        V_dc = rng.choice((540.0, rng.uniform(10, 2000)))
        r = V_dc * rng.choice((rng.uniform(0, 1.2), rng.uniform(0.5, 0.7), 10 ** rng.uniform(-3, 300)))
        ang, rho = rng.uniform(-math.pi, math.pi), rng.uniform(-10, 10)
        vd, vq = r * math.cos(ang), r * math.sin(ang)
        if rng.random() < 0.02:
            vd, vq = rng.choice(((math.inf, 1.0), (-math.inf, math.inf), (math.nan, 2.0), (3.0, -math.inf)))
            seen["nonfinite"] += 1
        c, s = math.cos(rho), math.sin(rho)
        for over in (0, 1):
            py = limit_voltage(vd, vq, c, s, V_dc, bool(over))
            cd, cq = D(vd), D(vq)
            lim = lib.sm_voltage_limit(ctypes.byref(cd), ctypes.byref(cq), c, s, V_dc, over)
            for a, b in ((cd.value, py[0]), (cq.value, py[1])):
                assert a == b or (a != a and b != b), (vd, vq, c, s, V_dc, over, (cd.value, cq.value), py)
            assert bool(lim) == py[2]
            seen["over" if over else "lin"] += py[2]
        if math.isfinite(vd) and V_dc / math.sqrt(3.0) < math.hypot(vd, vq) <= 2 * V_dc / 3:
            seen["between"] += 1
    print(f"[native law] voltage limit cases: {seen}")
    assert min(seen.values()) >= 50, seen


def test_control_overmodulation(lib, motors):
    """sm_control with modulation = overmodulation against control(): the same floats."""
    rng = random.Random(36)
    w = Worst("control, overmodulation")
    n_lim = 0
    for label, p, buf in motors:
        for _ in range(150):
            g, cg = random_gains(rng)
            cfg = ControllerConfig(V_dc=rng.choice((540.0, rng.uniform(50, 2000))),
                                   Ts=rng.choice((0.0, 1e-4)), load_mode=rng.choice(("known", "estimated")),
                                   modulation="overmodulation")
            ccfg = LawConfig(cfg.V_dc, cfg.Ts, cfg.phi_min, cfg.load_mode == "estimated", cfg.g_theta,
                             cfg.theta_max, cfg.use_stator_flux, 1)
            meas, ref = random_meas(rng), random_ref(rng)
            load = (rng.uniform(-30, 30), rng.uniform(-1e3, 1e3))
            i_max = random_i_max(rng)
            py = control(meas, ref, load, p, g, cfg, 0.0, (0.0, 0.0), i_max)
            c = ControlOut()
            assert lib.sm_control(arr(meas), arr(ref), arr(load), buf, ctypes.byref(cg), ctypes.byref(ccfg),
                                  0.0, arr((0.0, 0.0)), i_max, ctypes.byref(c)) == 0
            for name, v in zip(OUT_NAMES, py):
                if name in OUT_FLAGS:
                    assert bool(getattr(c, name)) == v, (name, label, meas, ref)
                else:
                    w.check(name, getattr(c, name), v, (label, meas, ref, cfg))
            n_lim += py.voltage_limited
    w.report()
    assert n_lim >= 50


def test_control_near_operating_points(lib, motors):
    """Measurements of consistent plant states near a flux and speed reference (the law's usual
    regime: small errors, no limit active), with psi_s for the stator-flux option."""
    rng = random.Random(17)
    w = Worst("control (operating points)")
    plain = 0
    for label, p, buf in motors:
        plant = Plant(p)
        for _ in range(200):
            phi = rng.uniform(0.3, 1.1)
            imd = p.curve.current(phi / p.k)  # about the steady state k m i_mu_d = Phi_rd
            x_fo = (phi, imd * rng.uniform(0.99, 1.01), rng.uniform(-8, 8), rng.uniform(-120, 120))
            x = to_stationary(p, x_fo, rng.uniform(-math.pi, math.pi))
            o = plant.outputs(x)
            meas = (o.i_s_alpha, o.i_s_beta, x[2], x[3], x[0], x[1], x[4])
            ref = (phi * rng.uniform(0.98, 1.02), rng.uniform(-1, 1), rng.uniform(-50, 50),
                   x_fo[3] + rng.uniform(-2, 2), rng.uniform(-100, 100), rng.uniform(-1e3, 1e3))
            g, cg = random_gains(rng)
            cfg = ControllerConfig(V_dc=rng.choice((540.0, 5000.0)),
                                   load_mode=rng.choice(("known", "estimated")),
                                   use_stator_flux=rng.random() < 0.5)
            ccfg = LawConfig(cfg.V_dc, cfg.Ts, cfg.phi_min, cfg.load_mode == "estimated", cfg.g_theta,
                             cfg.theta_max, cfg.use_stator_flux)
            load = (rng.uniform(-20, 20), 0.0)
            theta_hat, integ = rng.uniform(-500, 500), (rng.uniform(-1e-4, 1e-4), rng.uniform(-0.01, 0.01))
            i_max = rng.choice((math.inf, 40.0))
            py = control(meas, ref, load, p, g, cfg, theta_hat, integ, i_max)
            c = ControlOut()
            assert lib.sm_control(arr(meas), arr(ref), arr(load), buf, ctypes.byref(cg), ctypes.byref(ccfg),
                                  theta_hat, arr(integ), i_max, ctypes.byref(c)) == 0
            for name, v in zip(OUT_NAMES, py):
                if name in OUT_FLAGS:
                    assert bool(getattr(c, name)) == v, name
                else:
                    w.check(name, getattr(c, name), v, (label, meas, ref, cfg))
            plain += not (py.voltage_limited or py.singular_limited or py.current_limited)
    w.report()
    print(f"[native law] operating points without an active limit: {plain} of {200 * len(motors)}")
    assert plain >= 500


def test_control_nonfinite_inputs(lib, motors):
    """A NaN or inf in any input the law reads: SM_ERR_NONFINITE (3), never a crash.  Python raises
    for some of them (ArithmeticError of the polynomial curve, math.cos(inf), a division by 0.0);
    where it returns, the C outputs are its outputs, except |i_mu| for an infinite |w| (the C solve
    gives NaN, Python's inf) and the sign of the voltage-limit fallback for a NaN voltage (the
    sign bit of a NaN is not reproduced)."""
    base = (3.0, -1.0, 0.8, 0.1, 0.9, 0.2, 100.0)
    ref0 = (0.9, 0.0, 0.0, 100.0, 0.0, 0.0)
    g = Gains()
    lib.sm_gains_default(ctypes.byref(g))
    raised = compared = 0
    for label, p, buf in motors[::2]:
        for sf in (False, True):
            for mode in ("known", "estimated"):
                cfg = ControllerConfig(use_stator_flux=sf, load_mode=mode)
                ccfg = LawConfig(cfg.V_dc, cfg.Ts, cfg.phi_min, mode == "estimated", cfg.g_theta,
                                 cfg.theta_max, sf)
                for bad in (math.nan, math.inf, -math.inf):
                    for slot in range(18):
                        meas, ref, load, th, integ = list(base), list(ref0), [1.0, 0.0], 0.0, [0.0, 0.0]
                        if slot < 7:
                            meas[slot] = bad
                        elif slot < 13:
                            ref[slot - 7] = bad
                        elif slot < 15:
                            load[slot - 13] = bad
                        elif slot == 15:
                            th = bad
                        else:
                            integ[slot - 16] = bad
                        read = not ((slot in (4, 5) and not sf) or (slot in (13, 14) and mode == "estimated")
                                    or (slot == 15 and mode == "known"))
                        c = ControlOut()
                        st = lib.sm_control(arr(meas), arr(ref), arr(load), buf, ctypes.byref(g),
                                            ctypes.byref(ccfg), th, arr(integ), 30.0, ctypes.byref(c))
                        assert st == (3 if read else 0), (label, sf, mode, bad, slot)
                        try:
                            py = control(tuple(meas), tuple(ref), tuple(load), p, BacksteppingGains(), cfg,
                                         th, tuple(integ), 30.0)
                        except (ArithmeticError, ValueError):
                            raised += 1
                            continue
                        compared += 1
                        for name, v in zip(OUT_NAMES, py):
                            cv, v = float(getattr(c, name)), float(v)
                            if cv == v or (cv != cv and v != v):
                                continue
                            if name == "i_mu" and math.isnan(cv) and math.isinf(v):
                                continue
                            if name in ("v_sd", "v_sq", "v_s_alpha", "v_s_beta") and c.voltage_limited and (
                                    math.isnan(c.v_sd + c.v_sq) or abs(cv) == abs(v)):
                                continue
                            raise AssertionError((label, sf, mode, bad, slot, name, cv, v))
    print(f"\n[native law] non-finite inputs: Python raised {raised}, compared {compared}")
    assert raised and compared
    cfg = LawConfig()
    lib.sm_law_config_default(ctypes.byref(cfg))
    _, _, buf = motors[0]
    assert lib.sm_control(None, arr(ref0), None, buf, ctypes.byref(g), ctypes.byref(cfg), 0.0, None,
                          math.inf, ctypes.byref(ControlOut())) == 4
    assert lib.sm_control(arr(base), arr(ref0), None, buf, ctypes.byref(g), ctypes.byref(cfg), 0.0, None,
                          math.inf, ctypes.byref(ControlOut())) == 4  # the known mode reads load


# ------------------------------------------------------------------------ parameter checks


def py_message(cls, **kw):
    try:
        cls(**kw)
    except ParameterError as exc:
        return str(exc)
    return None


@pytest.mark.parametrize("field, value", [
    ("c1", 0.0), ("c1", -1.0), ("c2", math.nan), ("d1", math.inf), ("d2", -2.5e-7), ("c0", -1.0),
    ("d0", -math.inf), ("d0", math.nan), ("c0", 0.0)])
def test_gains_check(lib, field, value):
    g = Gains()
    lib.sm_gains_default(ctypes.byref(g))
    assert lib.sm_gains_check(ctypes.byref(g), None, 0) == 0
    setattr(g, field, value)
    msg = ctypes.create_string_buffer(256)
    st = lib.sm_gains_check(ctypes.byref(g), msg, 256)
    expected = py_message(BacksteppingGains, **{field: value})
    assert (st == 0) == (expected is None)
    if expected is not None:
        assert st == 1 and msg.value.decode() == expected


@pytest.mark.parametrize("field, value", [
    ("V_dc", 0.0), ("V_dc", math.nan), ("Ts", -1e-4), ("Ts", 0.0), ("phi_min", 0.0), ("phi_min", math.inf),
    ("g_theta", -5.0), ("theta_max", 0.0), ("theta_max", 1e16), ("Ts", 1e-05)])
def test_config_check(lib, field, value):
    cfg = LawConfig()
    lib.sm_law_config_default(ctypes.byref(cfg))
    assert lib.sm_law_config_check(ctypes.byref(cfg), None, 0) == 0
    setattr(cfg, field, value)
    msg = ctypes.create_string_buffer(256)
    st = lib.sm_law_config_check(ctypes.byref(cfg), msg, 256)
    expected = py_message(ControllerConfig, **{field: value})
    assert (st == 0) == (expected is None)
    if expected is not None:
        assert st == 1 and msg.value.decode() == expected


@pytest.mark.parametrize("field", ["load_estimated", "use_stator_flux", "overmodulation"])
def test_config_flags(lib, field):
    cfg = LawConfig()
    lib.sm_law_config_default(ctypes.byref(cfg))
    setattr(cfg, field, 2)
    msg = ctypes.create_string_buffer(256)
    assert lib.sm_law_config_check(ctypes.byref(cfg), msg, 256) == 1
    assert msg.value.decode().startswith(f"{field} = 2: must be ")


def test_defaults_are_pythons(lib):
    g, cfg = Gains(), LawConfig()
    lib.sm_gains_default(ctypes.byref(g))
    lib.sm_law_config_default(ctypes.byref(cfg))
    pg, pc = BacksteppingGains(), ControllerConfig()
    assert [getattr(g, n) for n in ("c1", "c2", "d1", "d2", "c0", "d0")] == [
        pg.c1, pg.c2, pg.d1, pg.d2, pg.c0, pg.d0]
    assert (cfg.V_dc, cfg.Ts, cfg.phi_min, cfg.load_estimated, cfg.g_theta, cfg.theta_max,
            cfg.use_stator_flux) == (pc.V_dc, pc.Ts, pc.phi_min, pc.load_mode == "estimated", pc.g_theta,
                                     pc.theta_max, pc.use_stator_flux)
    assert cfg.overmodulation == (pc.modulation == "overmodulation") == 0


# ------------------------------------------------------------------------------ the shaper


def test_transition_matrix_and_rise_time(lib):
    rng = random.Random(15)
    w = Worst("transition_matrix")
    for _ in range(500):
        bw, h = 10 ** rng.uniform(-1, 4), 10 ** rng.uniform(-6, 0)
        P = (D * 9)()
        assert lib.sm_transition_matrix(bw, h, P, None, 0) == 0
        py = transition_matrix(bw, h)
        for i in range(9):
            w.check(f"P[{i}]", P[i], py[i // 3][i % 3], (bw, h))
    w.report()
    assert lib.sm_rise_time_product() == RISE_TIME_PRODUCT


def test_shaper_sequences(lib):
    rng = random.Random(16)
    w = Worst("ReferenceShaper.step")
    n = 0
    for _ in range(60):
        bw = 10 ** rng.uniform(0, 3.5)
        init = rng.uniform(-100, 100)
        py = ReferenceShaper(bw, init)
        c = Shaper()
        assert lib.sm_shaper_init(ctypes.byref(c), bw, init, None, 0) == 0
        hs = (1e-4, 5e-5, rng.uniform(1e-6, 1e-2))
        u = init
        out = (D * 3)()
        for k in range(300):
            if rng.random() < 0.05:
                u = rng.uniform(-200, 200)  # a set-point step
            elif rng.random() < 0.3:
                u += rng.uniform(-1, 1)  # a ramp-like change
            h = rng.choice(hs) if rng.random() < 0.9 else rng.uniform(1e-6, 1e-2)
            r = py.step(u, h)
            assert lib.sm_shaper_step(ctypes.byref(c), u, h, out, None, 0) == 0
            for i in range(3):
                w.check(f"r[{i}]", out[i], r[i], (bw, k, u, h))
            n += 1
            if rng.random() < 0.01:
                v = rng.uniform(-50, 50)
                py.reset(v)
                assert lib.sm_shaper_reset(ctypes.byref(c), v, None, 0) == 0
            if rng.random() < 0.01:
                s = (rng.uniform(-50, 50), rng.uniform(-1e3, 1e3), rng.uniform(-1e5, 1e5))
                py.set_state(s)
                assert lib.sm_shaper_set_state(ctypes.byref(c), arr(s), None, 0) == 0
        z = (D * 3)()
        lib.sm_shaper_get_state(ctypes.byref(c), z)
        assert tuple(z) == py.get_state()
    w.report()
    assert n == 60 * 300


def py_error(fn, *args):
    try:
        fn(*args)
    except ParameterError as exc:
        return str(exc)
    raise AssertionError("no ParameterError")


def test_shaper_errors(lib):
    msg = ctypes.create_string_buffer(256)
    c = Shaper()
    for bw in (0.0, -1.0, math.nan, math.inf):
        assert lib.sm_shaper_init(ctypes.byref(c), bw, 0.0, msg, 256) == 1
        assert msg.value.decode() == py_error(ReferenceShaper, bw, 0.0)
    assert lib.sm_shaper_init(ctypes.byref(c), 100.0, math.nan, msg, 256) == 1
    assert msg.value.decode() == py_error(ReferenceShaper, 100.0, math.nan)
    py = ReferenceShaper(100.0, 1.0)
    assert lib.sm_shaper_init(ctypes.byref(c), 100.0, 1.0, msg, 256) == 0
    for h in (0.0, -1e-4, math.nan, math.inf):
        assert lib.sm_shaper_step(ctypes.byref(c), 2.0, h, None, msg, 256) == 1
        assert msg.value.decode() == py_error(py.step, 2.0, h)
    for u in (math.nan, -math.inf):
        assert lib.sm_shaper_step(ctypes.byref(c), u, 1e-4, None, msg, 256) == 1
        assert msg.value.decode() == py_error(py.step, u, 1e-4)
    assert lib.sm_shaper_reset(ctypes.byref(c), math.inf, msg, 256) == 1
    assert msg.value.decode() == py_error(py.reset, math.inf)
    bad = (1.0, math.nan, 0.0)
    assert lib.sm_shaper_set_state(ctypes.byref(c), arr(bad), msg, 256) == 1
    assert msg.value.decode() == py_error(py.set_state, bad)
    z = (D * 3)()
    lib.sm_shaper_get_state(ctypes.byref(c), z)
    assert tuple(z) == py.get_state() == (1.0, 0.0, 0.0)  # nothing moved on an error


# ------------------------------------------------------------------------------- sanitizers

SANITIZED_LAW_RUN = textwrap.dedent("""
    import ctypes, itertools, math, random, sys
    sys.path.insert(0, {tests!r})
    import native_core as nc
    import test_native_core_law as t
    lib = nc.declare(ctypes.CDLL({lib!r}))
    D, arr = ctypes.c_double, t.arr
    msg, big = ctypes.create_string_buffer(8), ctypes.create_string_buffer(4096)
    rng = random.Random(3)
    specials = (math.nan, math.inf, -math.inf, 0.0, -0.0, 1e-300, 1e300, 5e-324)
    g, cfg = t.Gains(), t.LawConfig()
    lib.sm_gains_default(ctypes.byref(g))
    lib.sm_law_config_default(ctypes.byref(cfg))
    for n in (0, 1, 8, 4096):
        buf = ctypes.create_string_buffer(max(n, 1))
        for f in ("c1", "c0"):
            gg = t.Gains(); lib.sm_gains_default(ctypes.byref(gg)); setattr(gg, f, math.nan)
            lib.sm_gains_check(ctypes.byref(gg), buf, n)
        cc = t.LawConfig(); lib.sm_law_config_default(ctypes.byref(cc)); cc.load_estimated = -7
        lib.sm_law_config_check(ctypes.byref(cc), buf, n)
        s = t.Shaper()
        lib.sm_shaper_init(ctypes.byref(s), math.nan, 0.0, buf, n)
        lib.sm_shaper_init(ctypes.byref(s), 100.0, 0.0, buf, n)
        lib.sm_shaper_set_state(ctypes.byref(s), arr((math.nan, -math.inf, 1e-300)), buf, n)
    for name in ("arctan", "exponential", "polynomial", "linear"):
        p = nc.new_motor(lib)
        st = lib.sm_motor_init(p, nc.params(lib, nc.MotorParams, dict(k=0.9, curve=name)), None, big, 4096)
        assert st == 0, big.value
        for k in range(3000):
            meas = [rng.uniform(-30, 30) for _ in range(7)]
            ref = [rng.uniform(-300, 300) for _ in range(6)]
            load = [rng.uniform(-30, 30), rng.uniform(-1e3, 1e3)]
            integ = [rng.uniform(-1, 1), rng.uniform(-1, 1)]
            if k % 2:  # one special value in one input
                v = rng.choice(specials)
                which = rng.randrange(4)
                [meas, ref, load, integ][which][rng.randrange(2)] = v
            cfg.load_estimated, cfg.use_stator_flux = k % 3 == 0, k % 5 == 0
            i_max = rng.choice((math.inf, 5.0, math.nan, 0.0, -3.0, 1e300))
            out = t.ControlOut()
            lib.sm_control(arr(meas), arr(ref), arr(load), p, ctypes.byref(g), ctypes.byref(cfg),
                           rng.choice((0.0, math.nan, 1e9)), arr(integ), i_max, ctypes.byref(out))
            es = t.ErrorState()
            lib.sm_error_system(arr(meas[:4]), arr(ref), p, ctypes.byref(g), load[0], load[1],
                                rng.choice((0.05, 0.0, math.nan)), arr((5.0, 1e4)) if k % 2 else None, None,
                                i_max, ctypes.byref(es))
        lib.sm_control(None, None, None, None, None, None, 0.0, None, 0.0, None)
        lib.sm_error_system(None, None, None, None, 0.0, 0.0, 0.0, None, None, 0.0, None)
        lib.sm_control(arr(meas), arr(ref), None, p, ctypes.byref(g), ctypes.byref(cfg), 0.0, None, 1.0, None)
    s = t.Shaper()
    lib.sm_shaper_init(ctypes.byref(s), 300.0, 0.0, msg, 8)
    out = (D * 3)()
    for k in range(3000):
        u = rng.choice(specials) if k % 7 == 0 else rng.uniform(-100, 100)
        h = rng.choice(specials) if k % 11 == 0 else rng.choice((1e-4, 1e-3))
        lib.sm_shaper_step(ctypes.byref(s), u, h, out if k % 2 else None, msg, 8)
    lib.sm_shaper_step(None, 0.0, 1e-4, None, None, 0)
    print("SANITIZED LAW RUN OK")
""")


def test_under_address_and_undefined_behaviour_sanitizers(tmp_path):
    gcc = shutil.which("gcc")
    asan = subprocess.run([gcc, "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    if not os.path.isabs(asan) or not os.path.exists(asan):
        pytest.skip("no libasan runtime")
    lib = build(SANITIZE, tmp_path)
    script = tmp_path / "run.py"
    script.write_text(SANITIZED_LAW_RUN.format(tests=str(Path(__file__).parent), lib=str(lib)))
    env = dict(os.environ, LD_PRELOAD=asan, ASAN_OPTIONS="detect_leaks=0:abort_on_error=0:exitcode=99",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:exitcode=98")
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=120)
    report = res.stdout + res.stderr
    assert res.returncode == 0 and "SANITIZED LAW RUN OK" in res.stdout, report[-4000:]
    assert "AddressSanitizer" not in report and "runtime error" not in report, report[-4000:]

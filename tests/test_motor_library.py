"""The library of named motors (satmotor/machine/library.py) and ``motor: {preset: ...}`` in scenarios; the
plant FMUs on the measured 2.2-kW machine (Qu et al. 2012) against an independent Gamma-model simulation.

The reference is written here from the Gamma-equivalent equations of Qu et al. / motulator, in complex
space vectors, with its own saturation law ``L_s(psi) = 0.34 / (1 + (0.84 |psi_s|)^7)`` (not the
polynomial curve object) and its own fixed-step RK4 at a tenth of the communication step (checked
against a run at a twentieth)::

    i_s = psi_s / L_s(|psi_s|) - i_R,   i_R = (psi_R - psi_s) / L_sigma
    psi_s' = u_s - R_s i_s,   psi_R' = -R_R i_R + j n_p omega_m psi_R
    J omega_m' = 3/2 n_p Im(conj(psi_s) i_s) - T_L
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from orchestration.packaging import fmus
from orchestration.run.fmu_instance import FMUInstance
from orchestration.scenario.load import load_scenario
from orchestration.scenario.validate import check_scenario_file
from satmotor.errors import ParameterError
from satmotor.machine.library import MOTORS, preset

QU = preset("qu2012_2kw2")
R_S, R_R, L_SIG, N_P, J = 3.7, 2.5, 0.023, 2, 0.015
V, W_E = 400.0 * math.sqrt(2.0 / 3.0), 2.0 * math.pi * 50.0
H, T_END, T_LOAD_AT, T_LOAD = 1e-4, 1.0, 0.5, 14.6


def test_library_entries_have_sources_nameplates_and_params():
    assert {"default_4kw", "qu2012_2kw2"} <= set(MOTORS)
    for m in MOTORS.values():
        assert m.source and m.nameplate.P_n > 0
        p = m.params()
        assert p.n_p == m.nameplate.n_p
        # rated power = rated torque x rated speed
        assert m.nameplate.T_n * m.nameplate.n_n * math.pi / 30.0 == pytest.approx(m.nameplate.P_n, rel=1e-3)
    p = QU.params()
    assert (p.R_s, p.R_r, p.l_s, p.l_r, p.k, p.J) == (R_S, R_R, 0.0, L_SIG, 1.0, J)
    for psi in (0.2, 0.9, 1.04, 1.3):  # the curve is Qu's L_s(psi), exactly
        I = p.curve.current(psi)
        assert psi / I == pytest.approx(0.34 / (1.0 + (0.84 * psi) ** 7), rel=1e-14)
    with pytest.raises(ParameterError, match="preset"):
        preset("nonesuch")


def _scenario(tmp_path, motor, controller="{}"):
    f = tmp_path / "s.yaml"
    f.write_text(textwrap.dedent(f"""\
        name: s
        stop_time: 0.1
        motor: {motor}
        controller: {controller}
        profiles:
          psi_ref: {{type: constant, value: 0.9}}
        """))
    return f


def test_a_preset_sets_both_units_and_takes_overrides(tmp_path):
    sc = load_scenario(_scenario(tmp_path, "{preset: qu2012_2kw2, J: 0.03}", "{c1: 150.0}"))
    for unit in (sc.plant, sc.controller):
        assert unit["l_s"] == 0.0 and unit["poly_n"] == 8 and unit["J"] == 0.03 and unit["R_s"] == R_S
    assert sc.controller["c1"] == 150.0 and sc.controller["c2"] == QU.controller["c2"]
    assert sc.controller["I_max"] == QU.controller["I_max"]
    assert not sc.notes  # no mismatch: the plant and the controller get the same motor


def test_an_unknown_preset_is_a_problem_naming_the_field(tmp_path):
    problems, _ = check_scenario_file(_scenario(tmp_path, "{preset: qu2013, J: 0.03}"))
    assert [p.field for p in problems] == ["motor.preset"]
    assert "qu2012_2kw2" in problems[0].message and "qu2013" in str(problems[0])


def _gamma_reference(h_fine):
    """Independent DOL start with a load step: states at every communication point ``k H``."""
    def L_s(psi):
        return 0.34 / (1.0 + (0.84 * psi) ** 7)

    def f(ps, pr, w, u, tl):
        i_R = (pr - ps) / L_SIG
        i_s = ps / L_s(abs(ps)) - i_R
        return (u - R_S * i_s, -R_R * i_R + 1j * N_P * w * pr,
                (1.5 * N_P * (ps.conjugate() * i_s).imag - tl) / J), i_s

    n, sub = round(T_END / H), round(H / h_fine)
    dt = H / sub
    ps = pr = 0j
    w = 0.0
    out = np.empty((n + 1, 5))
    out[0] = 0.0
    for k in range(n):
        t = k * H
        u = V * complex(math.cos(W_E * (t + 0.5 * H)), math.sin(W_E * (t + 0.5 * H)))  # held over the step
        tl = T_LOAD if t >= T_LOAD_AT - 1e-12 else 0.0
        for _ in range(sub):
            (a1, b1, c1), _ = f(ps, pr, w, u, tl)
            (a2, b2, c2), _ = f(ps + 0.5 * dt * a1, pr + 0.5 * dt * b1, w + 0.5 * dt * c1, u, tl)
            (a3, b3, c3), _ = f(ps + 0.5 * dt * a2, pr + 0.5 * dt * b2, w + 0.5 * dt * c2, u, tl)
            (a4, b4, c4), _ = f(ps + dt * a3, pr + dt * b3, w + dt * c3, u, tl)
            ps += dt / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
            pr += dt / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
            w += dt / 6.0 * (c1 + 2 * c2 + 2 * c3 + c4)
        i_s = f(ps, pr, w, u, tl)[1]
        out[k + 1] = (w, i_s.real, i_s.imag, pr.real, pr.imag)
    return out


@pytest.fixture(scope="module")
def gamma_reference():
    ref, check = _gamma_reference(H / 10), _gamma_reference(H / 20)
    scale = np.max(np.abs(ref), axis=0)
    own = float(np.max(np.abs(ref - check) / scale))
    print(f"Gamma reference: h/10 against h/20, max relative difference {own:.2e}")
    assert own < 1e-9
    return ref


def _run_fmu(path, values):
    inst = FMUInstance(path, "qu2012")
    try:
        inst.set_parameters(values)
        inst.initialize(0.0)
        s = inst.slave
        get = s.getFloat64 if inst.fmi3 else s.getReal
        set_ = s.setFloat64 if inst.fmi3 else s.setReal
        vin = inst.vr(("v_s_alpha", "v_s_beta", "T_load"))
        vout = inst.vr(("omega_m", "i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta"))
        n = round(T_END / H)
        out = np.empty((n + 1, 5))
        out[0] = get(vout)
        for k in range(n):
            t = k * H
            tm = t + 0.5 * H
            set_(vin, [V * math.cos(W_E * tm), V * math.sin(W_E * tm),
                       T_LOAD if t >= T_LOAD_AT - 1e-12 else 0.0])
            inst.do_step(t, H)
            out[k + 1] = get(vout)
        return out
    finally:
        inst.close()


@pytest.mark.parametrize("variant", ["python", "native", "native-fmi3"])
def test_plant_fmu_on_the_qu_machine_matches_an_independent_gamma_model(variant, fmu_dir, gamma_reference):
    """A 1-s direct-on-line start with a rated-load step at 0.5 s: speed, stator currents and rotor flux
    within 1e-6 (relative to each signal's peak) of the Gamma-model reference."""
    plant, _ = fmus.paths(fmu_dir, variant)
    got = _run_fmu(plant, dict(QU.values))
    ref = gamma_reference
    names = ("omega_m", "i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta")
    errs = {nm: float(np.max(np.abs(got[:, j] - ref[:, j])) / np.max(np.abs(ref[:, j])))
            for j, nm in enumerate(names)}
    worst = max(errs.values())
    print(f"{variant}: max relative error {worst:.2e} " + ", ".join(f"{k} {v:.1e}" for k, v in errs.items()))
    assert ref[-1, 0] > 140.0 and ref[round(T_LOAD_AT / H), 0] > 150.0  # it ran up, then took the load
    assert worst <= 1e-6, errs

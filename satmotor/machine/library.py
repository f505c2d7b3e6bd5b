"""Named motors: parameter sets with their nameplate and their source, selectable in a scenario.

A scenario selects one with ``motor: {preset: NAME}``, and may override any of its motor
parameters beside it (``motor: {preset: qu2012_2kw2, J: 0.03}``).  A preset also carries the
controller settings suited to the machine (gains, current limit), applied to the controller unit
under the scenario's own ``controller:`` section.  ``docs/motors.md`` lists them with their
nameplates.

==============  ==================================================================================
name            machine and source
==============  ==================================================================================
default_4kw     4 kW, 400 V, 50 Hz, 1430 rpm: the Simscape "4 kW 400 V 50 Hz 1430 rpm" preset's
                resistances, leakages, inertia and friction with our arctan curve (T form); the
                default of :class:`~satmotor.machine.params.MotorParams`
qu2012_2kw2     2.2 kW, 400 V, 5 A, 50 Hz, 14.6 N m, measured: Z. Qu, M. Ranta, M. Hinkkanen,
                J. Luomi, "Adaptive loss-minimizing control of vector-controlled induction motor
                drives", IEEE Trans. Ind. Appl. 48(3), 2012, doi 10.1109/TIA.2012.2190818.
                Gamma form: R_s = 3.7 Ohm, R_R = 2.5 Ohm, L_sigma = 0.023 H,
                L_s(psi) = 0.34 / (1 + (0.84 psi)^7) H, n_p = 2, J = 0.015 kg m2 (the same data as
                the motulator drive library's saturated 2.2-kW example).  In the seed's form: l_s = 0,
                k = 1, l_r = 0.023 H, the polynomial curve I = psi/0.34 + (0.84^7/0.34) psi^8 (exact).
                No friction is given (B = 0).
==============  ==================================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType

from satmotor.errors import ParameterError
from satmotor.machine.forms import GammaForm, polynomial_from_inductance
from satmotor.machine.magnetics import ArctanCurve, PolynomialCurve
from satmotor.machine.params import MotorParams, SupplyMixin, make_curve

__all__ = ["Nameplate", "NamedMotor", "MOTORS", "preset", "preset_names"]


@dataclass(frozen=True)
class Nameplate(SupplyMixin):
    """Rated data: P_n [W] shaft power, V_n [V] line-to-line rms, I_n [A] line rms, f_n [Hz],
    n_n [rpm] rated speed, T_n [N m] rated torque, n_p pole pairs."""

    P_n: float
    V_n: float
    I_n: float
    f_n: float
    n_n: float
    T_n: float
    n_p: int

    @property
    def I_peak(self):
        """Rated current amplitude [A] = sqrt(2) I_n."""
        return math.sqrt(2.0) * self.I_n


@dataclass(frozen=True)
class NamedMotor:
    """A motor of the library: ``values`` the flat motor parameters (the names of
    ``satmotor.interface.MOTOR_PARAMETERS``; the others keep their defaults), ``controller`` the
    controller settings suited to it, ``psi_rated`` [Wb] its rated rotor flux (no-load, rated
    voltage and frequency), ``source`` where the numbers come from."""

    name: str
    title: str
    nameplate: Nameplate
    values: MappingProxyType
    controller: MappingProxyType
    psi_rated: float
    source: str
    notes: str = ""
    # the machine's plant-only data (satmotor.interface.PLANT_MOTOR_NAMES: core loss, thermal constants);
    # empty: the plant's defaults (those of the default motor)
    plant: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))

    def params(self):
        """The :class:`MotorParams` of this motor."""
        v = self.values
        a, p = ArctanCurve(), PolynomialCurve()  # the defaults of the flat parameters not given
        curve = make_curve(v["curve"], v.get("L_m0", a.L_m0), v.get("L_m_inf", a.L_m_inf),
                           v.get("I_par", a.I_par), v.get("poly_b", p.poly_b), v.get("poly_n", p.poly_n),
                           v.get("table_file", ""))
        return MotorParams(v["R_s"], v["R_r"], v["l_s"], v["l_r"], v["k"], v["n_p"], v["J"], v["B"], curve)


def _default_4kw():
    m, a = MotorParams(), ArctanCurve()
    values = dict(R_s=m.R_s, R_r=m.R_r, l_s=m.l_s, l_r=m.l_r, k=m.k, n_p=m.n_p, J=m.J, B=m.B,
                  curve="arctan", L_m0=a.L_m0, L_m_inf=a.L_m_inf, I_par=a.I_par)
    return NamedMotor(
        "default_4kw", "4 kW, 400 V, 50 Hz, 1430 rpm (the default motor)",
        Nameplate(P_n=4000.0, V_n=400.0, I_n=7.9, f_n=50.0, n_n=1430.0,
                  T_n=4000.0 / (1430.0 * math.pi / 30.0), n_p=2),
        MappingProxyType(values), MappingProxyType({}), 0.98,
        "MATLAB/Simscape Electrical Asynchronous Machine preset '4 kW, 400 V, 50 Hz, 1430 rpm' (R_s, R_r, "
        "l_s, l_r, J, B); the arctan curve is ours (satmotor/machine/params.py)",
        "I_n is not in the preset: 7.9 A rms is this model's current at rated load after a DOL start "
        "(docs/model.md); psi_rated: the curve's design point (5.7 A peak)")


def _qu2012_2kw2():
    curve = polynomial_from_inductance(0.34, 0.84, 7)
    g = GammaForm(R_s=3.7, R_R=2.5, L_sigma=0.023, curve=curve).to_motor(n_p=2, J=0.015, B=0.0)
    values = dict(R_s=g.R_s, R_r=g.R_r, l_s=g.l_s, l_r=g.l_r, k=g.k, n_p=g.n_p, J=g.J, B=g.B,
                  curve="polynomial", L_m0=curve.L_m0, poly_b=curve.poly_b, poly_n=curve.poly_n)
    # gains: c1 near the rotor's natural rate R_R/L_sigma = 109 1/s; d1 = 50 1/s makes a 10 rad/s speed
    # error ask J * 500 = 7.5 N m, half the rated torque; inner loops 5x the outer ones (as the default
    # motor's gains); I_max 1.5 times the rated current amplitude (as motulator's example)
    ctrl = dict(c1=100.0, c2=500.0, d1=50.0, d2=250.0, I_max=round(1.5 * math.sqrt(2.0) * 5.0, 2))
    plate = Nameplate(P_n=2200.0, V_n=400.0, I_n=5.0, f_n=50.0, n_n=2200.0 / 14.6 * 30.0 / math.pi,
                      T_n=14.6, n_p=2)
    return NamedMotor(
        "qu2012_2kw2", "2.2 kW, 400 V, 5 A, 50 Hz, 14.6 N m, measured (Qu et al. 2012)",
        plate, MappingProxyType(values), MappingProxyType(ctrl),
        plate.V_phase_peak / (2.0 * math.pi * plate.f_n),
        "Z. Qu, M. Ranta, M. Hinkkanen, J. Luomi, IEEE Trans. Ind. Appl. 48(3), 2012, "
        "doi 10.1109/TIA.2012.2190818 (Gamma form); the same data as motulator's saturated 2.2-kW example",
        "n_n = P_n / T_n (1439 rpm); psi_rated = V_phase_peak / (2 pi f_n) at no load; B not given (0); "
        "thermal constants an estimate (docs/motors.md), no core loss given (R_fe = 0)",
        # thermal: an estimate for a 2.2-kW TEFC machine (frame 90L, about 17 kg): stator 9 kg, rotor 3.5 kg;
        # at rated load (stator copper 277 W + core about 50 W, rotor about 120 W) rises of about 83 K
        MappingProxyType(dict(C_th_s=4200.0, C_th_r=1600.0, R_th_s=0.25, R_th_r=0.7, R_th_sr=0.2)))


MOTORS = MappingProxyType({m.name: m for m in (_default_4kw(), _qu2012_2kw2())})


def preset_names():
    """The names of the library's motors."""
    return tuple(MOTORS)


def preset(name):
    """The :class:`NamedMotor` called ``name``; :class:`ParameterError` naming ``preset`` otherwise."""
    try:
        return MOTORS[name]
    except (KeyError, TypeError):
        raise ParameterError("preset", name, f"must be one of {', '.join(MOTORS)}") from None

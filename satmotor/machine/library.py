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
msl_imc_18kw5   18.5 kW, 400 V delta, 32.85 A, 50 Hz, 1462.5 rpm, 120.79 N m: the machine of the
                Modelica Standard Library's ``IMC_withLosses`` example (A. Haumer, C. Kral et al.,
                "The AdvancedMachines library: loss models for electric machines", Modelica 2009),
                with its published loss split; unsaturated (the linear curve), the star equivalent of
                its delta data, R_s and R_r at 20 C (run at 90 C: T_s0 = T_r0 = 363.15 K)
haumer_112m04   4 kW, IEC frame 112M, 400 V star, 8.493 A, 50 Hz, 1431.57 rpm, 26.682 N m: A. Haumer's
                ``ElectricalMachines.ParameterRecords.IMCdata.Imc112M04`` record (friction 60 W, core
                90 W, stray 20 W); unsaturated, R_s and R_r at 20 C (run at 95 C: 368.15 K)
==============  ==================================================================================

The two Modelica machines carry their loss models in this project's terms (docs/motors.md): friction
``P_ref (w/w_ref)^3`` (the library's ``power_w = 2``) as ``k_wind = P_ref / w_ref^3``; stray load
``P_ref (I/I_ref)^2 (w/w_ref)^2`` (``power_w = 1``) as ``k_stray = P_ref / (|i_ref|^2 w_ref^2)`` with
``|i_ref|`` the reference current's space-vector amplitude (sqrt 2 times the line rms); the core loss
conductance ``P_ref / (3 V_ref^2)`` per phase at the reference inner voltage as ``R_fe = 3 V_ref^2 /
P_ref`` (star phase voltage), the temperature coefficients the library's (copper 3.92e-3, aluminium
4.0e-3 1/K at 20 C).
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


# the Modelica library's temperature coefficients at 20 C (Modelica.Electrical.Machines.Thermal.Constants)
MSL_ALPHA_COPPER, MSL_ALPHA_ALUMINIUM = 3.92e-3, 4.0e-3


def _modelica_motor(name, title, plate, phase, J, core, friction, stray, source, notes):
    """A Modelica library machine (unsaturated): ``phase`` = (R_s, X_s_sigma, X_m, X_r_sigma, R_r) [Ohm]
    of the star equivalent at f_n (resistances at 20 C), ``core`` = (P_ref [W], V_ref [V] star phase
    rms), ``friction`` = P_ref [W] at the rated speed, ``stray`` = (P_ref [W], I_ref [A] line rms) at the
    rated speed; the loss laws as the module docstring says."""
    R_s, X_s, X_m, X_r, R_r = phase
    w_e, w_n = plate.omega_e, plate.n_n * math.pi / 30.0
    values = dict(R_s=R_s, R_r=R_r, l_s=X_s / w_e, l_r=X_r / w_e, k=1.0, n_p=plate.n_p, J=J, B=0.0,
                  curve="linear", L_m0=X_m / w_e)
    i_ref = math.sqrt(2.0) * stray[1]
    plant = dict(R_fe=3.0 * core[1] ** 2 / core[0], alpha_s=MSL_ALPHA_COPPER, alpha_r=MSL_ALPHA_ALUMINIUM,
                 k_wind=friction / w_n ** 3, k_stray=stray[0] / (i_ref * i_ref * w_n * w_n))
    ctrl = dict(I_max=round(1.5 * plate.I_peak, 2))
    return NamedMotor(name, title, plate, MappingProxyType(values), MappingProxyType(ctrl),
                      plate.V_phase_peak / w_e, source, notes, MappingProxyType(plant))


def _msl_imc_18kw5():
    plate = Nameplate(P_n=18500.0, V_n=400.0, I_n=32.85, f_n=50.0, n_n=1462.5, T_n=120.79, n_p=2)
    i_n = plate.I_n
    return _modelica_motor(
        "msl_imc_18kw5", "18.5 kW, 400 V delta, 32.85 A, 50 Hz, 1462.5 rpm (Modelica IMC_withLosses)", plate,
        # the delta phase data divided by 3 (the star equivalent)
        tuple(z / 3.0 for z in (0.56, 1.52, 66.40, 2.31, 0.42)), 0.12,
        (410.0, 387.9 / math.sqrt(3.0)), 180.0,
        (0.005 * math.sqrt(3.0) * 400.0 * i_n * 0.898, i_n),
        "Modelica Standard Library, Modelica.Electrical.Machines.Examples.InductionMachines.IMC_withLosses "
        "(and its quasi-static twin); A. Haumer, C. Kral, H. Kapeller, T. Baeuml, J. V. Gragger, \"The "
        "AdvancedMachines library: loss models for electric machines\", 7th Modelica Conference, 2009",
        "delta-connected machine as its star equivalent (impedances / 3, I_ref of the stray loss the line "
        "current); published at 90 C: run with T_s0 = T_r0 = 363.15 K; core loss 410 W at the inner voltage "
        "387.9 V (delta phase); stray 0.5 % of the rated input; gains the defaults (not tuned)")


def _haumer_112m04():
    plate = Nameplate(P_n=4000.0, V_n=400.0, I_n=8.493, f_n=50.0, n_n=1431.57, T_n=26.682, n_p=2)
    return _modelica_motor(
        "haumer_112m04", "4 kW, frame 112M, 400 V star, 8.493 A, 50 Hz, 1431.57 rpm (Haumer Imc112M04)",
        plate,
        (1.45, 2.25, 49.65, 2.75, 1.05), 0.008, (90.0, 400.0 / math.sqrt(3.0)), 60.0, (20.0, plate.I_n),
        "A. Haumer, ElectricalMachines (github.com/AHaumer/ElectricalMachines), "
        "ParameterRecords/IMCdata/Imc112M04.mo and Examples.IMC_NominalOperation",
        "published at 95 C: run with T_s0 = T_r0 = 368.15 K; core loss 90 W at the reference inner voltage "
        "V_sN = 400/sqrt 3 V (the record's default VRef), friction 60 W and stray 20 W at the rated speed "
        "(and current); gains the defaults (not tuned)")


MOTORS = MappingProxyType({m.name: m for m in (_default_4kw(), _qu2012_2kw2(), _msl_imc_18kw5(),
                                               _haumer_112m04())})


def preset_names():
    """The names of the library's motors."""
    return tuple(MOTORS)


def preset(name):
    """The :class:`NamedMotor` called ``name``; :class:`ParameterError` naming ``preset`` otherwise."""
    try:
        return MOTORS[name]
    except (KeyError, TypeError):
        raise ParameterError("preset", name, f"must be one of {', '.join(MOTORS)}") from None

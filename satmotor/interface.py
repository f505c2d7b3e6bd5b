"""The two co-simulation units, FMI-agnostic: variable tables, flat parameters, step and state.

The tables below are the single source of the units' interfaces: the FMU slaves register their
variables from them, the FMU documentation is generated from them, and the plain-Python
reference uses the same units.  Defaults come from the parameter dataclasses (no number is
written twice).  Units are in the descriptions and, added by the build
(``orchestration.packaging.fmu_model_description``), in the FMUs' ``unit`` attributes.
"""

from __future__ import annotations

import dataclasses
import math
import operator
import sys
from typing import NamedTuple

from satmotor.control.backstepping import LOAD_MODES, BacksteppingGains, ControllerConfig
from satmotor.control.deadtime import compensate
from satmotor.control.drive import (
    FLUX_MODES,
    FLUX_SOURCES,
    HOST_DELAY_MAX,
    OBSERVERS,
    SPEED_SOURCES,
    BacksteppingDrive,
    DriveConfig,
    DriveOutput,
    IFOCDrive,
)
from satmotor.control.ifoc import IFOCGains
from satmotor.control.measurements import MEAS_I_S_A, MEAS_I_S_B, MEAS_LEN, MEAS_OMEGA_M
from satmotor.control.modulation import MODULATIONS
from satmotor.converter.dc_link import (
    DC_LINK_MODES,
    DC_SOURCES,
    DCLink,
    DCLinkParams,
    over_voltage_message,
)
from satmotor.converter.inverter import INVERTERS, InverterParams, PwmInverter
from satmotor.errors import ParameterError, require_choice, require_integer, require_number
from satmotor.machine.losses import LOSS_NAMES, LossParams, switching_power
from satmotor.machine.magnetics import ArctanCurve, LinearCurve, PolynomialCurve
from satmotor.machine.params import CURVE_NAMES, MotorParams, make_curve
from satmotor.machine.phases import phase_currents
from satmotor.machine.plant import (
    OMEGA_M,
    PSI_R_A,
    PSI_R_B,
    PSI_S_A,
    PSI_S_B,
    THETA_M,
    Plant,
    initial_state,
)
from satmotor.machine.thermal import ThermalParams


class Variable(NamedTuple):
    """One exposed variable: name, causality (input/output/parameter), type (Real, Integer,
    String), start value, unit, description and, for a parameter, the C parameter struct of the
    native core whose member of the same name it fills (``c_struct``: ``motor`` is
    ``sm_motor_params``; see ``orchestration/packaging/native/tables.py``).  ``choices``: a String
    parameter's closed set of values (empty: any text, a file name); the checks in Python use the
    same tuple, the native core a C enum and parser generated from it (``sm_choice_parse``), the
    scenario loader refuses any other value.  ``fills``: the settings (keys of :data:`SETTINGS`) whose
    field of the parameter's name it fills, in Python (:class:`ControllerUnit`) and in C (the member of
    that name of ``sm_<setting>``, or its coding in ``tables.DATACLASS_STRUCTS``: the copy
    ``sm_controller_settings`` is generated from this field)."""

    name: str
    causality: str
    type: str
    start: object
    unit: str
    description: str
    c_struct: str = ""
    choices: tuple[str, ...] = ()
    fills: tuple[str, ...] = ()


def _in_struct(c_struct, variables):
    """``variables`` with ``c_struct`` set: each fills the member of its name of ``sm_<c_struct>_params``."""
    return tuple(v._replace(c_struct=c_struct) for v in variables)


def _v(name, causality, start, unit, description, type_="Real", choices=(), fills=()):
    return Variable(name, causality, type_, start, unit, description, choices=tuple(choices), fills=fills)


# the controller's settings dataclasses its flat parameters fill (Variable.fills), by the name of their
# C struct (sm_gains, ...: each field the member of its name, but the coded ones of
# orchestration/packaging/native/tables.py's DATACLASS_STRUCTS)
SETTINGS = {"gains": BacksteppingGains, "law_config": ControllerConfig, "drive_config": DriveConfig,
            "ifoc_gains": IFOCGains}


# max_substeps' default: one doStep(0, 5 s) at the limit (h_int = 1e-4 s) took 1.35-1.40 s on the
# pythonfmu plant (27-28 us per sub-step; PlantUnit alone 11-12 us) and 0.03-0.13 s on the native one
# (0.5-2.5 us, by curve), on the project's 2-core machine shared by other jobs (load average 3.5)
MAX_SUBSTEPS = 50_000
# max_samples' default: doStep(0, 1000 s) = 10^7 samples took 89 s on the pythonfmu controller and 1.3 s
# on the native one (issue 31); one doStep of 100000 samples took 1.46 s and 0.03 s (load average 9). The
# master steps the controller by Ts (one sample), so no library scenario comes near it
MAX_STEP_SAMPLES = 100_000
PLANT_DESCRIPTION = ("Induction motor with main-flux saturation and cross-saturation, stationary alpha-beta "
                     "frame, flux states, RK4 (Ouadi, Giri, Ikhouane model, corrected)")
CONTROLLER_DESCRIPTION = ("Backstepping speed and rotor-flux controller for the saturated induction motor "
                          "(seed eq 67, corrected), with pre-magnetization, reference shaping, adaptive load "
                          "estimate and the constant-m and IFOC PI baselines")
AUTHOR = "satmotor"

_M, _A, _P, _L, _TH = MotorParams(), ArctanCurve(), PolynomialCurve(), DCLinkParams(), ThermalParams()
_G, _C, _D = BacksteppingGains(), ControllerConfig(), DriveConfig()
_INV = InverterParams(V_dc=_L.V_dc)  # the plant's inverter: its link voltage the dclink V_dc
_LP = LossParams()
OMEGA_WARN = 1500.0  # [rad/s] omega_warn's default: about 10 x the default motor's synchronous speed
MOTOR_PARAMETERS = _in_struct("motor", (
    _v("R_s", "parameter", _M.R_s, "Ohm", "stator resistance"),
    _v("R_r", "parameter", _M.R_r, "Ohm", "rotor resistance (rotor side; k = 1: referred)"),
    _v("l_s", "parameter", _M.l_s, "H", "stator leakage inductance"),
    _v("l_r", "parameter", _M.l_r, "H", "rotor leakage inductance"),
    _v("k", "parameter", _M.k, "1", "turns ratio k = k_r n_r / (k_s n_s), i_mu = i_s + k i_r"),
    _v("n_p", "parameter", _M.n_p, "1", "pole pairs", "Integer"),
    _v("J", "parameter", _M.J, "kg m2", "rotor and load inertia"),
    _v("B", "parameter", _M.B, "N m s", "viscous friction"),
    _v("curve", "parameter", "arctan", "", "magnetizing curve: " + ", ".join(CURVE_NAMES), "String",
       CURVE_NAMES),
    _v("L_m0", "parameter", _A.L_m0, "H", "unsaturated magnetizing inductance (all curves)"),
    _v("L_m_inf", "parameter", _A.L_m_inf, "H", "saturated slope (arctan, exponential)"),
    _v("I_par", "parameter", _A.I_par, "A", "knee current scale (arctan, exponential)"),
    _v("poly_b", "parameter", _P.poly_b, "A/Wb^n", "polynomial: i = psi/L_m0 + poly_b psi^poly_n"),
    _v("poly_n", "parameter", _P.poly_n, "1", "polynomial: integer exponent >= 2 (of |psi|)", "Integer"),
    _v("table_file", "parameter", "", "", "table: CSV file of no-load points i_mu [A], psi_m [Wb]",
       "String"),
))

PLANT_INPUTS = (
    _v("v_s_alpha", "input", 0.0, "V", "stator voltage, alpha axis (amplitude-invariant Clarke)"),
    _v("v_s_beta", "input", 0.0, "V", "stator voltage, beta axis"),
    _v("T_load", "input", 0.0, "N m", "load torque (opposes positive speed)"),
)
PLANT_OUTPUTS = (
    _v("i_s_alpha", "output", 0.0, "A", "stator current, alpha axis"),
    _v("i_s_beta", "output", 0.0, "A", "stator current, beta axis"),
    _v("psi_s_alpha", "output", 0.0, "Wb", "stator flux linkage, alpha axis"),
    _v("psi_s_beta", "output", 0.0, "Wb", "stator flux linkage, beta axis"),
    _v("psi_r_alpha", "output", 0.0, "Wb", "rotor flux linkage, alpha axis"),
    _v("psi_r_beta", "output", 0.0, "Wb", "rotor flux linkage, beta axis"),
    _v("omega_m", "output", 0.0, "rad/s", "mechanical speed"),
    _v("theta_m", "output", 0.0, "rad", "mechanical angle"),
    _v("T_e", "output", 0.0, "N m", "electromagnetic torque 3/2 n_p (psi_s x i_s)"),
    _v("i_mu", "output", 0.0, "A", "magnitude of the magnetizing current i_s + k i_r"),
    # the DC link (satmotor.converter.dc_link), last
    _v("v_dc", "output", _L.V_dc, "V", "DC-link voltage (dc_link = ideal: the parameter V_dc)"),
    _v("E_regen", "output", 0.0, "J", "energy the motor returned into the DC link, int max(0, -3/2 v_s.i_s) "
       "dt (dc_link = capacitor; ideal: 0)"),
    _v("E_chop", "output", 0.0, "J", "energy dissipated in the brake chopper (dc_link = capacitor; "
       "ideal: 0)"),
    # a Real 0/1 (not a Boolean): the plant's output port is all Real (hosts, the master, the ME plant)
    _v("dc_fault", "output", 0.0, "1", "DC-link over-voltage fault, 0 or 1: 1 once v_dc exceeded V_dc_max "
       "(latched; a warning logged once, the physics goes on)"),
    # issue 19 (last: the earlier outputs keep their value references)
    _v("P_fe", "output", 0.0, "W", "core (iron) loss 3/2 |e_s|^2 / R_fe, with the input held over the step "
       "just ended; 0 without R_fe"),
    _v("T_s", "output", _TH.T_s0, "K", "stator temperature (thermal off: T_s0, constant)"),
    _v("T_r", "output", _TH.T_r0, "K", "rotor temperature (thermal off: T_r0, constant)"),
    # last: the inverter's (satmotor.converter.inverter)
    _v("v_avg_alpha", "output", 0.0, "V", "stator voltage applied by the inverter, alpha axis, averaged over "
       "the last communication step (inverter = average: v_s_alpha)"),
    _v("v_avg_beta", "output", 0.0, "V", "stator voltage applied by the inverter, beta axis, averaged over "
       "the last communication step (inverter = average: v_s_beta)"),
    # issue 35, every loss (satmotor.machine.losses; last: the earlier outputs keep their value references).
    # At the step's end (like P_fe) but P_inv, P_chop and P_in: their means over the last communication step
    # (model exchange: all at the instant)
    _v("P_cu_s", "output", 0.0, "W", "stator copper loss 3/2 R_s(T_s) |i_s|^2 (the terminal current)"),
    _v("P_cu_r", "output", 0.0, "W", "rotor copper loss 3/2 R_r(T_r) |i_r|^2"),
    _v("P_fw", "output", 0.0, "W", "friction and windage loss (B omega_m + T_fric sign(omega_m) + k_wind "
       "omega_m |omega_m|) omega_m"),
    _v("P_stray", "output", 0.0, "W", "stray-load loss k_stray |i_s|^2 omega_m^2 (a braking torque)"),
    _v("P_inv", "output", 0.0, "W", "inverter loss: on-state drops (pwm) and switching (E_sw), the mean over "
       "the last communication step (average inverter: its switching loss at the step's end)"),
    _v("P_chop", "output", 0.0, "W", "brake chopper loss v_dc i_chop, the mean over the last communication "
       "step (dc_link = capacitor; else 0)"),
    _v("P_in", "output", 0.0, "W", "power drawn from the DC link, 3/2 v_s.i_s + P_inv, the mean over the "
       "last communication step"),
    _v("P_mech", "output", 0.0, "W", "shaft power delivered to the load (T_load + B_2 omega_m |omega_m|) "
       "omega_m"),
)
# the outputs of the communication step just ended in co-simulation: its means (P_inv, P_chop, P_in) and
# P_mech with the load held over it (the model-exchange plant's: at the instant, with the input as it is;
# PlantUnit.instant)
STEP_MEAN_OUTPUTS = ("P_inv", "P_chop", "P_in", "P_mech")
PLANT_PARAMETERS = MOTOR_PARAMETERS + _in_struct("plant", (
    _v("omega_m0", "parameter", 0.0, "rad/s", "initial mechanical speed"),
    _v("psi_r0", "parameter", 0.0, "Wb", "initial rotor flux (DC, on the alpha axis; 0: unmagnetized)"),
    _v("h_int", "parameter", 1e-4, "s", "largest internal RK4 step; a communication step dt uses "
       "ceil(dt/h_int) equal sub-steps"),
    # last: the earlier variables keep their value references
    _v("B_2", "parameter", 0.0, "N m s2/rad2", "quadratic (fan/pump) load: torque B_2 omega_m |omega_m| "
       "opposing motion, >= 0; plant only (the controller sees it as an unknown load)"),
)) + _in_struct("plant", (
    # the unit's step limit and plausibility bounds (sm_plant_unit.c reads them from sm_plant_params)
    _v("max_substeps", "parameter", MAX_SUBSTEPS, "1", "most internal RK4 sub-steps one doStep may take, "
       ">= 1: a longer step is discarded naming the step size and this limit (bounds the work per call; "
       "the default is about 1 s of the pythonfmu plant, under 0.1 s of the native one)", "Integer"),
    # plausibility: a warning, logged once per run and quantity, never a change of the result
    _v("v_warn", "parameter", 4.0 * _C.V_dc, "V", "stator voltage magnitude |v_s| (input) above which a "
       "warning is logged, once per run (default 4 V_dc of the controller's default); 0: no check"),
    _v("i_warn", "parameter", 10.0 * _D.I_max, "A", "stator current magnitude |i_s| (after a step) above "
       "which a warning is logged, once per run (default 10 I_max of the drive's default); 0: no check"),
    _v("omega_warn", "parameter", OMEGA_WARN, "rad/s", "mechanical speed |omega_m| (after a step) above "
       "which a warning is logged, once per run (default about 10 x the default motor's synchronous speed, "
       "157 rad/s); 0: no check"),
)) + _in_struct("dclink", (  # the DC link (satmotor.converter.dc_link.DCLinkParams), last
    _v("dc_link", "parameter", _L.dc_link, "", "DC link: " + ", ".join(DC_LINK_MODES) + " (ideal: a constant "
       "V_dc, the command applied as it is; capacitor: C_dc fed by dc_source, |v_s| bounded by v_dc/sqrt(3))",
       "String", DC_LINK_MODES),
    _v("V_dc", "parameter", _L.V_dc, "V", "DC-link voltage (ideal; the one the pwm inverter switches), or "
       "the capacitor's initial voltage and the dc source's voltage (capacitor), > 0; default the "
       "controller's V_dc"),
    _v("C_dc", "parameter", _L.C_dc, "F", "DC-link capacitance, > 0 (capacitor)"),
    _v("dc_source", "parameter", _L.dc_source, "", "what feeds the capacitor through a diode and R_src: "
       + ", ".join(DC_SOURCES) + " (dc: the voltage V_dc; rectifier: a six-pulse diode bridge on the grid "
       "V_grid, f_grid)", "String", DC_SOURCES),
    _v("R_src", "parameter", _L.R_src, "Ohm", "source resistance, > 0 (capacitor)"),
    _v("V_grid", "parameter", _L.V_grid, "V", "grid voltage, line-to-line rms (dc_source = rectifier), > 0"),
    _v("f_grid", "parameter", _L.f_grid, "Hz", "grid frequency (dc_source = rectifier), > 0"),
    _v("V_chop_on", "parameter", _L.V_chop_on, "V", "brake chopper: switches on above this link voltage"),
    _v("V_chop_off", "parameter", _L.V_chop_off, "V", "brake chopper: switches off below this link voltage "
       "(< V_chop_on: the hysteresis)"),
    _v("R_chop", "parameter", _L.R_chop, "Ohm", "brake chopper resistor, >= 0 (0: no chopper)"),
    _v("V_dc_max", "parameter", _L.V_dc_max, "V", "over-voltage: v_dc above it sets dc_fault and logs a "
       "warning once (the physics goes on), >= 0 (0: no check); above V_chop_on with a chopper (R_chop > 0)"),
)) + _in_struct("plant", (
    # issue 19, core loss and temperature (last: the earlier variables keep their value references);
    # plant only: the controller keeps its own R_s, R_r (cold) and knows no core loss
    _v("R_fe", "parameter", 0.0, "Ohm", "core-loss resistance across the stator emf d psi_s/dt (behind R_s; "
       "l_s = 0: across the magnetizing branch), >= 0; 0: no core loss; plant only"),
    _v("thermal", "parameter", _TH.thermal, "", "two-body thermal model on: T_s, T_r are states and "
       "R_s(T_s), R_r(T_r) follow them; off: the temperatures stay at T_s0, T_r0", "Boolean"),
    _v("T_amb", "parameter", _TH.T_amb, "K", "ambient (cooling air) temperature, > 0"),
    _v("T_s0", "parameter", _TH.T_s0, "K", "initial stator temperature, > 0"),
    _v("T_r0", "parameter", _TH.T_r0, "K", "initial rotor temperature, > 0"),
    _v("T_ref", "parameter", _TH.T_ref, "K", "temperature at which R_s and R_r are given, > 0"),
    _v("alpha_s", "parameter", _TH.alpha_s, "1/K", "temperature coefficient of R_s (copper), >= 0"),
    _v("alpha_r", "parameter", _TH.alpha_r, "1/K", "temperature coefficient of R_r (aluminium cage), >= 0"),
    _v("C_th_s", "parameter", _TH.C_th_s, "J/K", "heat capacity of the stator (winding and core), > 0"),
    _v("C_th_r", "parameter", _TH.C_th_r, "J/K", "heat capacity of the rotor, > 0"),
    _v("R_th_s", "parameter", _TH.R_th_s, "K/W", "thermal resistance stator to ambient, > 0"),
    _v("R_th_r", "parameter", _TH.R_th_r, "K/W", "thermal resistance rotor to ambient, > 0"),
    _v("R_th_sr", "parameter", _TH.R_th_sr, "K/W", "thermal resistance stator to rotor (air gap), > 0"),
)) + _in_struct("plant", (
    # last: the inverter (satmotor.converter.inverter); the earlier variables keep their value references.
    # Its link voltage is the dclink parameter V_dc (one parameter)
    _v("inverter", "parameter", _INV.inverter, "", "stator voltage source: average (the commanded voltage as "
       "it is, the average-value model) or pwm (carrier-comparison PWM inverter on the link voltage V_dc, "
       "switching instants integrated exactly; co-simulation only; dc_link = ideal, R_fe = 0 and thermal "
       "= false only)", "String", INVERTERS),
    _v("f_sw", "parameter", _INV.f_sw, "Hz", "pwm: switching (triangular carrier) frequency, > 0; the duty "
       "cycles are sampled at every carrier peak and valley"),
    _v("t_dead", "parameter", _INV.t_dead, "s", "pwm: dead time of every leg, 0 <= t_dead < 1/(2 f_sw); "
       "during it the phase current's sign sets the voltage"),
    _v("v_on", "parameter", _INV.v_on, "V", "pwm: on-state voltage drop of a conducting device or diode, "
       "0 <= v_on < V_dc/2"),
)) + _in_struct("plant", (
    # issue 35, the mechanical and inverter losses (satmotor.machine.losses; last: the earlier variables keep
    # their value references); plant only, all off by default
    _v("T_fric", "parameter", _LP.T_fric, "N m", "constant (Coulomb) friction torque T_fric sign(omega_m) "
       "opposing motion, >= 0; 0: none"),
    _v("k_wind", "parameter", _LP.k_wind, "N m s2/rad2", "windage: torque k_wind omega_m |omega_m| opposing "
       "motion, >= 0; 0: none"),
    _v("k_stray", "parameter", _LP.k_stray, "N m s/(A2 rad)", "stray-load loss: torque k_stray |i_s|^2 "
       "omega_m opposing motion (loss k_stray |i_s|^2 omega_m^2), >= 0; 0: none"),
    _v("E_sw", "parameter", _LP.E_sw, "J", "switching energy E_on + E_off of one device at V_sw_ref, "
       "I_sw_ref (a datasheet's); an edge dissipates E_sw/2 (v_dc/V_sw_ref)(|i|/I_sw_ref), >= 0; 0: none"),
    _v("V_sw_ref", "parameter", _LP.V_sw_ref, "V", "the link voltage at which E_sw is given, > 0"),
    _v("I_sw_ref", "parameter", _LP.I_sw_ref, "A", "the current at which E_sw is given, > 0"),
))
# the machine's data only the plant models: a scenario's motor: section and a preset may hold them (the
# controller's model ignores them)
PLANT_MOTOR_NAMES = ("R_fe", "T_ref", "alpha_s", "alpha_r", "C_th_s", "C_th_r", "R_th_s", "R_th_r", "R_th_sr",
                     "T_fric", "k_wind", "k_stray")
THERMAL_NAMES = ("thermal", "T_amb", "T_s0", "T_r0", "T_ref", "alpha_s", "alpha_r", "C_th_s", "C_th_r",
                 "R_th_s", "R_th_r", "R_th_sr")

CONTROLLER_MODES = ("saturated", "constant_m", "pi")
CONTROLLER_INPUTS = (
    _v("i_s_alpha", "input", 0.0, "A", "measured stator current, alpha axis"),
    _v("i_s_beta", "input", 0.0, "A", "measured stator current, beta axis"),
    _v("psi_r_alpha", "input", 0.0, "Wb", "measured rotor flux, alpha axis"),
    _v("psi_r_beta", "input", 0.0, "Wb", "measured rotor flux, beta axis"),
    _v("psi_s_alpha", "input", 0.0, "Wb", "measured stator flux, alpha axis (used with use_stator_flux)"),
    _v("psi_s_beta", "input", 0.0, "Wb", "measured stator flux, beta axis (used with use_stator_flux)"),
    _v("omega_m", "input", 0.0, "rad/s", "measured mechanical speed"),
    _v("omega_ref", "input", 0.0, "rad/s", "speed set-point (shaped inside)"),
    _v("psi_ref", "input", 0.9, "Wb", "rotor flux set-point (shaped inside), > 0"),
    _v("T_load", "input", 0.0, "N m", "load torque, used in load_mode = known"),
    # last: the plant's DC link
    _v("v_dc", "input", 0.0, "V", "measured DC-link voltage (the plant's v_dc), >= 0: > 0 bounds |v_s| by "
       "v_dc/sqrt(3) (pre-magnetization, law, field weakening); 0: not connected, the parameter V_dc is "
       "used"),
)
CONTROLLER_OUTPUTS = (
    _v("v_s_alpha", "output", 0.0, "V", "stator voltage command, alpha axis (held over Ts)"),
    _v("v_s_beta", "output", 0.0, "V", "stator voltage command, beta axis"),
    _v("v_sd", "output", 0.0, "V", "stator voltage command, rotor-flux d axis"),
    _v("v_sq", "output", 0.0, "V", "stator voltage command, rotor-flux q axis"),
    _v("e1", "output", 0.0, "Wb", "flux error Phi_rd - psi_ref_shaped (before the law runs: "
       "Phi_rd - psi_ref)"),
    _v("e2", "output", 0.0, "Wb/s", "flux virtual-control error"),
    _v("z1", "output", 0.0, "rad/s", "speed error omega_m - omega_ref_shaped"),
    _v("z2", "output", 0.0, "rad/s2", "speed virtual-control error"),
    _v("W", "output", 0.0, "1", "det Lambda of the law (0: not running)"),
    _v("T_load_est", "output", 0.0, "N m", "load torque used by the law (estimate if estimated)"),
    _v("psi_r_hat_alpha", "output", 0.0, "Wb", "rotor flux the law uses, alpha axis: the observer's "
       "estimate (flux_source = observer) or the psi_r_alpha input (measured)"),
    _v("psi_r_hat_beta", "output", 0.0, "Wb", "rotor flux the law uses, beta axis"),
    _v("omega_ref_shaped", "output", 0.0, "rad/s", "shaped speed reference the law tracks (0 before the law "
       "runs: the shaper starts at the measured speed at the switch)"),
    _v("psi_ref_shaped", "output", 0.0, "Wb", "shaped rotor flux reference the law tracks (0 before the law "
       "runs: the shaper starts at the measured flux at the switch)"),
    _v("phase", "output", 0, "", "0: pre-magnetization (current loop), 1: run (the law)", "Integer"),
    _v("voltage_limited", "output", False, "", "the voltage vector was limited to V_dc/sqrt(3)",
       "Boolean"),
    _v("current_limited", "output", False, "", "a virtual control (or the pre-magnetization current) "
       "was bounded by I_max (or the lowered bound of current_limit_gain), or the measured |i_s| exceeds "
       "I_max", "Boolean"),
    _v("singular_limited", "output", False, "", "the law's singularity guard was active "
       "(flux below phi_min or det Lambda floored)", "Boolean"),
    _v("omega_m_hat", "output", 0.0, "rad/s", "mechanical speed the drive uses: the observer's estimate "
       "(speed_source = estimated) or the omega_m input (measured)"),
    # issue 33 (last: the earlier variables keep their value references)
    _v("R_s_hat", "output", 0.0, "Ohm", "stator resistance of the law's model after the sample: the "
       "observer's estimate (rs_adaptation) or the parameter R_s"),
    _v("R_r_hat", "output", 0.0, "Ohm", "rotor resistance of the law's model after the sample: from the "
       "temperature R_s_hat implies (rr_tracking) or the parameter R_r"),
)
# the outputs after DriveOutput's fields: properties of the drive (C: members of sm_drive_output)
DRIVE_PROPERTY_OUTPUTS = ("omega_m_hat", "R_s_hat", "R_r_hat")
CONTROLLER_PARAMETERS = _in_struct("controller", (
    _v("c1", "parameter", _G.c1, "1/s", "flux error gain", fills=("gains",)),
    _v("c2", "parameter", _G.c2, "1/s", "flux virtual-control gain", fills=("gains",)),
    _v("d1", "parameter", _G.d1, "1/s", "speed error gain", fills=("gains",)),
    _v("d2", "parameter", _G.d2, "1/s", "speed virtual-control gain", fills=("gains",)),
    _v("c0", "parameter", _G.c0, "1/s2", "flux integral gain (0: no integral action, the seed's law)",
       fills=("gains",)),
    _v("d0", "parameter", _G.d0, "1/s2", "speed integral gain (0: no integral action, the seed's law)",
       fills=("gains",)),
    _v("Ts", "parameter", _C.Ts, "s", "sample period; a doStep runs a whole number of samples "
       "(its step a multiple of Ts, at most max_samples)",
       fills=("law_config",)),
    _v("mode", "parameter", "saturated", "", "law: saturated (backstepping with the curve), "
       "constant_m (same law, m = L_m0), pi (indirect field-oriented PI baseline)", "String",
       CONTROLLER_MODES),
    _v("load_mode", "parameter", "known", "", "load torque: known (input T_load) or estimated", "String",
       LOAD_MODES, fills=("law_config",)),
    _v("V_dc", "parameter", _C.V_dc, "V", "DC-link voltage; |v_s| <= V_dc / sqrt(3)",
       fills=("law_config", "ifoc_gains")),
    _v("modulation", "parameter", _C.modulation, "", "voltage limit of the backstepping law: linear "
       "(|v_s| <= V_dc / sqrt(3)) or overmodulation (the command scaled, its direction kept, onto the "
       "inverter's hexagon: V_dc / sqrt(3) at the flats up to 2 V_dc / 3 at the vertices)", "String",
       MODULATIONS, fills=("law_config",)),
    _v("ref_bandwidth", "parameter", _D.ref_bandwidth, "rad/s", "reference shaper bandwidth",
       fills=("drive_config",)),
    _v("g_theta", "parameter", _C.g_theta, "1/s2", "adaptation gain of the load estimate",
       fills=("law_config",)),
    _v("theta_max", "parameter", _C.theta_max, "rad/s2", "bound of the estimate of T_load/J",
       fills=("law_config",)),
    _v("I_max", "parameter", _D.I_max, "A", "stator current limit: pre-magnetization, flux set-points, "
       "the law's virtual controls, the measured current (current_limit_gain)",
       fills=("drive_config", "ifoc_gains")),
    _v("flux_source", "parameter", _D.flux_source, "", "rotor flux: measured (the psi_r/psi_s inputs, "
       "the seed's assumption) or observer (estimated from i_s and omega_m; the psi inputs are ignored)",
       "String", FLUX_SOURCES, fills=("drive_config",)),
    _v("delay_samples", "parameter", _D.delay_samples, "1", "computational delay: 0 (voltage applied at "
       "the sample) or 1 (applied one sample later, compensated by prediction)", "Integer",
       fills=("drive_config",)),
    _v("use_stator_flux", "parameter", _C.use_stator_flux, "", "magnetizing state from the measured "
       "stator flux too (seed H1, eqs 18-19) instead of the curve alone", "Boolean", fills=("law_config",)),
    _v("observer", "parameter", _D.observer, "", "flux observer with flux_source = observer: closed_loop "
       "(current and voltage models blended by a speed-dependent gain, the curve inside) or current_model "
       "(open loop, from i_s and omega_m)", "String", OBSERVERS, fills=("drive_config",)),
    _v("speed_source", "parameter", _D.speed_source, "", "mechanical speed: measured (the omega_m input) or "
       "estimated (speed-adaptive closed-loop observer, the omega_m input is not read; needs flux_source = "
       "observer, observer = closed_loop)", "String", SPEED_SOURCES, fills=("drive_config",)),
    _v("field_weakening", "parameter", _D.field_weakening, "", "automatic field weakening: psi_ref is the "
       "nominal flux, lowered (on the magnetizing curve) where the steady stator voltage at the present "
       "torque and speed would exceed fw_voltage_ratio V_dc/sqrt(3); false: psi_ref as it is", "Boolean",
       fills=("drive_config",)),
    _v("fw_voltage_ratio", "parameter", _D.fw_voltage_ratio, "1", "share of V_dc/sqrt(3) a steady state "
       "may use under field weakening, in (0, 1]; the rest is the law's margin", fills=("drive_config",)),
    _v("premag_fraction", "parameter", _D.premag_fraction, "1", "pre-magnetization: the law takes over at "
       "this fraction of psi_ref, in (0, 1]", fills=("drive_config",)),
    _v("premag_min_fraction", "parameter", _D.premag_min_fraction, "1", "pre-magnetization: the law takes "
       "over from this fraction of psi_ref on (<= premag_fraction) when the rotor turns faster than "
       "premag_speed_tol or premag_time_max has passed", fills=("drive_config",)),
    _v("premag_speed_tol", "parameter", _D.premag_speed_tol, "rad/s", "pre-magnetization: |omega_m| above "
       "which a load is taken to turn the rotor (the flux current goes to 0.9 I_max), > 0",
       fills=("drive_config",)),
    _v("premag_time_max", "parameter", _D.premag_time_max, "s", "pre-magnetization: time after which the "
       "law takes over from premag_min_fraction on, > 0", fills=("drive_config",)),
    _v("premag_boost", "parameter", _D.premag_boost, "1", "pre-magnetization current as a multiple of the "
       "steady magnetizing current of psi_ref (bounded by I_max), >= 1", fills=("drive_config",)),
    _v("premag_gain", "parameter", _D.premag_gain, "Ohm", "proportional gain of the pre-magnetization "
       "current loop, > 0", fills=("drive_config",)),
)) + MOTOR_PARAMETERS + _in_struct("controller", (
    # last: the earlier variables keep their value references
    _v("current_limit_gain", "parameter", _D.current_limit_gain, "1/s", "measured-current limiter: while the "
       "measured |i_s| exceeds I_max the law's current bound is lowered by the integral of the excess times "
       "this gain (unwound below I_max); >= 0, 0: off (the law's model currents alone are bounded)",
       fills=("drive_config",)),
    _v("host_delay_samples", "parameter", _D.host_delay_samples, "1", "samples of coupling delay the host "
       "adds between this output and the plant's input (a Jacobi master: 1; Gauss-Seidel: 0), 0 to "
       f"{HOST_DELAY_MAX}; compensated with delay_samples by one prediction over both", "Integer",
       fills=("drive_config",)),
    _v("deadtime_comp_voltage", "parameter", 0.0, "V", "dead-time compensation: sign(i_phase) times this "
       "voltage added to each phase of the voltage command (from the measured currents), >= 0; 0: off "
       "(satmotor.control.deadtime)"),
    # issue 31 (last: the earlier variables keep their value references)
    _v("max_samples", "parameter", MAX_STEP_SAMPLES, "1", "most samples one doStep may run, >= 1: a longer "
       "step is discarded naming the step size and this limit (bounds the work per call; the default is "
       "about 1 s of the pythonfmu controller, under 0.1 s of the native one)", "Integer"),
    # issue 35, the loss-minimizing flux (last: the earlier variables keep their value references)
    _v("flux_mode", "parameter", _D.flux_mode, "", "rotor-flux set-point: nominal (psi_ref, lowered by the "
       "field weakening) or loss_minimizing (the flux of the least modelled stator and rotor copper and core "
       "loss at the present torque and speed on the magnetizing curve, at most that set-point, at least "
       "flux_floor, rate limited by flux_rate_max)", "String", FLUX_MODES, fills=("drive_config",)),
    _v("flux_floor", "parameter", _D.flux_floor, "Wb", "loss_minimizing: the lowest rotor-flux set-point, "
       "> 0", fills=("drive_config",)),
    _v("flux_rate_max", "parameter", _D.flux_rate_max, "V s/s", "loss_minimizing: the largest rate of change "
       "of the rotor-flux set-point (V s/s = Wb/s), > 0", fills=("drive_config",)),
    _v("loss_R_fe", "parameter", _D.loss_R_fe, "Ohm", "loss_minimizing: core-loss resistance of the loss "
       "model, across the stator emf (the plant's R_fe placement), >= 0; 0: copper loss only",
       fills=("drive_config",)),
    # issue 33 (last: the earlier variables keep their value references)
    _v("rs_adaptation", "parameter", _D.rs_adaptation, "", "stator-resistance adaptation in the closed-loop "
       "observer (the law uses the estimate, output R_s_hat); held before the law runs, while a limit is "
       "active and at low excitation; needs flux_source = observer, observer = closed_loop; false: R_s as "
       "given", "Boolean", fills=("drive_config",)),
    _v("rr_tracking", "parameter", _D.rr_tracking, "", "rotor-resistance (temperature) tracking: R_r from "
       "the temperature R_s_hat implies, rotor at the stator's temperature, in the observer and the law "
       "(output R_r_hat); needs rs_adaptation; false: R_r as given", "Boolean", fills=("drive_config",)),
))


def _filled():
    """Per setting of :data:`SETTINGS` the controller parameters that fill it (``Variable.fills``), in
    table order; each must be a field of that setting's dataclass."""
    out = {s: [] for s in SETTINGS}
    for v in CONTROLLER_PARAMETERS:
        for s in v.fills:
            if s not in SETTINGS:
                raise ValueError(f"CONTROLLER_PARAMETERS {v.name}: fills {s!r}, not one of "
                                 f"{', '.join(SETTINGS)}")
            if v.name not in {f.name for f in dataclasses.fields(SETTINGS[s])}:
                raise ValueError(f"CONTROLLER_PARAMETERS {v.name}: fills {s!r}, but "
                                 f"{SETTINGS[s].__name__} has no field {v.name}")
            out[s].append(v.name)
    return {s: tuple(names) for s, names in out.items()}


FILLED = _filled()  # setting -> the names of the parameters that fill its fields (the C copy's too)


def _sample_outputs():
    """The getter of a sample's outputs in the order of CONTROLLER_OUTPUTS from the drive's output: each
    output the field of its name of :class:`DriveOutput` but the last, ``DRIVE_PROPERTY_OUTPUTS``, the drive's
    property (C: each the member of its name of ``sm_drive_output``, copied by the generated
    ``sm_controller_outputs_of``)."""
    names = tuple(v.name for v in CONTROLLER_OUTPUTS)
    n = len(DRIVE_PROPERTY_OUTPUTS)
    if names[-n:] != DRIVE_PROPERTY_OUTPUTS or not set(names[:-n]) <= set(DriveOutput._fields):
        raise ValueError(f"CONTROLLER_OUTPUTS {names}: each must be a field of DriveOutput "
                         f"({', '.join(DriveOutput._fields)}) but the last: "
                         f"{', '.join(DRIVE_PROPERTY_OUTPUTS)}")
    return operator.itemgetter(*(DriveOutput._fields.index(n) for n in names[:-n]))  # by position: fastest


_SAMPLE_OUTPUTS = _sample_outputs()



class Terminal(NamedTuple):
    """An FMI 3.0 terminal (``terminalsAndIcons.xml``): a named group of variables a tool connects
    in one gesture.  ``members``: ``(member name, variable name)`` pairs; two terminals of the same
    ``name`` on the plant and the controller have the same member names, each an output on one side
    and an input on the other.  ``rule``: FMI's ``matchingRule`` (``plug``: every member matched;
    ``bus``: the members present on both sides)."""

    name: str
    kind: str
    rule: str
    description: str
    members: tuple[tuple[str, str], ...]


def _pair(prefix):
    return (("alpha", f"{prefix}_alpha"), ("beta", f"{prefix}_beta"))


_DRIVE = ("org.satmotor.DriveInterface", "plug")
_STATOR_VOLTAGE = Terminal("statorVoltage", *_DRIVE, "stator voltage command, alpha/beta [V]", _pair("v_s"))
_STATOR_CURRENT = Terminal("statorCurrent", *_DRIVE, "stator current, alpha/beta [A]", _pair("i_s"))
_ROTOR_FLUX = Terminal("rotorFlux", *_DRIVE, "rotor flux linkage, alpha/beta [Wb]", _pair("psi_r"))
_STATOR_FLUX = Terminal("statorFlux", *_DRIVE, "stator flux linkage, alpha/beta [Wb]", _pair("psi_s"))
_SPEED = Terminal("speed", *_DRIVE, "mechanical speed [rad/s]", (("omega", "omega_m"),))
# the plant-controller interface, each signal pair its own terminal; the shaft and the set-points for
# the tool's load and reference sources
PLANT_TERMINALS = (
    _STATOR_VOLTAGE, _STATOR_CURRENT, _ROTOR_FLUX, _STATOR_FLUX, _SPEED,
    Terminal("shaft", "org.satmotor.MechanicalShaft", "bus",
             "mechanical port: speed [rad/s], angle [rad], air-gap torque [N m], load torque [N m]",
             (("omega", "omega_m"), ("angle", "theta_m"), ("torque", "T_e"), ("loadTorque", "T_load"))),
)
CONTROLLER_TERMINALS = (
    _STATOR_VOLTAGE, _STATOR_CURRENT, _ROTOR_FLUX, _STATOR_FLUX, _SPEED,
    Terminal("setPoints", "org.satmotor.SetPoints", "bus",
             "speed [rad/s] and rotor-flux [Wb] set-points, load torque [N m]",
             (("speed", "omega_ref"), ("flux", "psi_ref"), ("loadTorque", "T_load"))),
)

def _number(values, var):
    v = values.get(var.name, var.start)
    if var.type == "Integer":
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        v = require_integer(var.name, v)
    elif var.type == "Real":
        v = require_number(var.name, v)
    elif var.type == "Boolean":
        if v in (0, 1):  # FMI hosts may hand a Boolean over as 0/1
            v = bool(v)
        if not isinstance(v, bool):
            raise ParameterError(var.name, v, "must be a Boolean")
    return v


def motor_params(values):
    """:class:`MotorParams` from flat values ``{name: value}`` (missing names take the defaults)."""
    f = {var.name: _number(values, var) for var in MOTOR_PARAMETERS}
    curve = make_curve(f["curve"], f["L_m0"], f["L_m_inf"], f["I_par"], f["poly_b"], f["poly_n"],
                       f["table_file"])
    return MotorParams(f["R_s"], f["R_r"], f["l_s"], f["l_r"], f["k"], f["n_p"], f["J"], f["B"], curve)


_CAST = {"Real": float, "Integer": int, "Boolean": bool}


def _finite_inputs(names, values):
    for name, v in zip(names, values):
        if not math.isfinite(v):  # per-step fast path; require_number raises
            require_number(name, v)


WARN_NAMES = ("v_warn", "i_warn", "omega_warn")
_WARN_WHAT = (("|v_s|", "V", "input"), ("|i_s|", "A", "output"), ("|omega_m|", "rad/s", "output"))


def plausibility_message(k, t, value, bound):
    """The warning for quantity ``k`` (0: |v_s|, 1: |i_s|, 2: |omega_m|) at ``t`` [s], as the native plant."""
    what, unit, kind = _WARN_WHAT[k]
    return (f"SaturatedInductionMotor: implausible {kind} at t = {t!r} s: {what} = {value!r} {unit} exceeds "
            f"{WARN_NAMES[k]} = {bound!r} {unit}; the step is computed as given (logged once per run)")


def substeps_reason(n_sub, h_int, max_substeps):
    """Why a communication step of ``n_sub`` sub-steps of ``h_int`` [s] is refused (as the native plant)."""
    return (f"needs {n_sub} RK4 sub-steps of h_int = {h_int!r} s, more than max_substeps = {max_substeps}: "
            "take shorter communication steps or raise max_substeps")


def dc_link(values):
    """:class:`DCLinkParams` from the plant's flat values (the ``dclink`` parameters; missing names take
    their defaults)."""
    return DCLinkParams(**{v.name: _number(values, v) for v in PLANT_PARAMETERS if v.c_struct == "dclink"})


def pwm_substeps_reason(n, f_sw, max_substeps):
    """Why a communication step of up to ``n`` RK4 sub-steps with the pwm inverter is refused."""
    return (f"needs up to {n} RK4 sub-steps with the pwm inverter (f_sw = {f_sw!r} Hz), more than "
            f"max_substeps = {max_substeps}: take shorter communication steps or raise max_substeps")


class PlantUnit:
    """The plant as a co-simulation unit: inputs held over each communication step."""

    INPUTS = tuple(v.name for v in PLANT_INPUTS)
    OUTPUTS = tuple(v.name for v in PLANT_OUTPUTS)

    def __init__(self, values):
        self.params = motor_params(values)
        f = {v.name: _number(values, v) for v in PLANT_PARAMETERS[len(MOTOR_PARAMETERS):]}
        w0, psi0 = f["omega_m0"], f["psi_r0"]
        require_number("psi_r0", psi0, 0, inclusive=True)
        self.h_int = require_number("h_int", f["h_int"], 0)
        self.max_substeps = require_integer("max_substeps", f["max_substeps"], 1)
        self._warn = tuple(require_number(n, f[n], 0, inclusive=True) for n in WARN_NAMES)
        self._warned = [False, False, False]
        self.warnings = []  # plausibility warnings not yet logged (the FMU glue takes them)
        self._o = None  # the plant's outputs at self.x, once computed (by the |i_s| check)
        # B_2 is the plant's alone: not in MotorParams, which is also the controller's model
        # so are R_fe and the thermal model (the controller keeps its cold R_s, R_r); the checks in
        # the native core's order: B_2, R_fe, then the thermal parameters
        require_number("B_2", f["B_2"], 0, inclusive=True)
        require_number("R_fe", f["R_fe"], 0, inclusive=True)
        self.plant = Plant(self.params, f["B_2"], f["R_fe"], ThermalParams(*(f[n] for n in THERMAL_NAMES)),
                           LossParams(*(f[n] for n in LOSS_NAMES)))
        self.x0 = initial_state(self.params, omega_m=w0, psi_r_alpha=psi0) + self.plant.thermal_state()
        # the stator voltage held over the last step (the outputs' with R_fe); pwm: its step average
        # (outputs v_avg_alpha/beta)
        self._v = (0.0, 0.0)
        self._thermal = self.plant.th.thermal
        self.link = dc_link(f)  # the DC link's parameters; a capacitor link integrates with the plant
        self._link = DCLink(self.plant, self.link) if self.link.capacitor else None
        if self._link is not None:
            self.x0 = self._link.initial_state(self.x0)
        self._chop, self._fault = False, False  # the chopper's state, the latched over-voltage fault
        self.x = self.x0
        self._dt, self._n_sub = None, 1  # the last step size and its sub-step count
        # the inverter switches the link's V_dc (one parameter; a capacitor link: its voltage, a state)
        inv = InverterParams(self.link.V_dc, f["inverter"], f["f_sw"], f["t_dead"], f["v_on"])
        self.inverter = PwmInverter(inv, self.plant.lp) if inv.inverter == "pwm" else None  # None: average
        self._f_sw = inv.f_sw
        # the load held over the last step (P_mech) and the step's means [W]: into the terminals 3/2 v_s.i_s,
        # the inverter's loss (pwm), the chopper's (a capacitor link)
        self._T_load = 0.0
        self._means = (0.0, 0.0, 0.0)
        self._pwm_means = (0.0, 0.0)  # pwm: the step's means of P_cu_s, P_fe [W]
        # the model-exchange plant's outputs (sm_plant_unit.instant): P_in, P_inv at the state and held
        # voltage (3/2 v_s.i_s), not a step's means, and no chopper
        self.instant = False

    def step(self, t, dt, inputs):
        """Advance over ``dt`` [s] with the inputs ``(v_s_alpha, v_s_beta, T_load)`` held;
        raises ParameterError on a bad input."""
        if not math.isfinite(sum(inputs)):  # per-step fast path: a finite sum has finite terms
            _finite_inputs(self.INPUTS, inputs)
        v_a, v_b, T_load = inputs
        if dt != self._dt:  # checked, and its sub-step count found, once per step size
            require_number("communicationStepSize", dt, 0)
            n_sub = max(1, math.ceil(dt / self.h_int - 1e-9))
            if n_sub > self.max_substeps:
                raise ParameterError("communicationStepSize", dt, substeps_reason(n_sub, self.h_int,
                                                                                  self.max_substeps))
            if self.inverter is not None and n_sub + self.inverter.intervals_bound(dt) > self.max_substeps:
                raise ParameterError("communicationStepSize", dt, pwm_substeps_reason(
                    n_sub + self.inverter.intervals_bound(dt), self.inverter.f_sw, self.max_substeps))
            self._n_sub = n_sub
            self._dt = dt
        if self._warn[0] > 0.0 and not self._warned[0]:
            self._plausible(0, t, v_a, v_b)
        before = None
        if self.inverter is not None:  # the switched voltages, integrated to the switching instants
            before = self.inverter.get_state()
            try:
                x, *v_avg = self.inverter.step(self.plant, t, self.x, v_a, v_b, T_load, dt, self.h_int,
                                               link=self._link, chop=self._chop, fault=self._fault)
            except Exception:  # a failed solve inside: the switching state as before the step
                self.inverter.set_state(before)
                raise
            if self._link is not None:
                chop, fault, t_fault = self.inverter.link_out
        elif self._link is not None:
            x, chop, fault, t_fault = self._link.step(t, self.x, v_a, v_b, T_load, dt, self._n_sub,
                                                      self._chop, self._fault)
            v_avg = (v_a, v_b)  # the command (the outputs' voltage: _held, the applied one)
        else:
            x = self.plant.step(t, self.x, v_a, v_b, T_load, dt, self._n_sub)
            v_avg = (v_a, v_b)
        if not math.isfinite(sum(x)) and not all(math.isfinite(v) for v in x):
            if self.inverter is not None:
                self.inverter.set_state(before)
            raise ArithmeticError(f"the plant state became non-finite over [{t}, {t + dt}] s: {x}")
        if self._link is not None:
            self._chop, self._fault = chop, fault
            if t_fault is not None:
                self.warnings.append(over_voltage_message(t_fault, x[self._link.iv], self.link.V_dc_max))
        x0 = self.x
        self.x = x
        self._v = tuple(v_avg)
        self._o = None
        self._T_load = T_load
        self._means = self._step_means(x0, x, dt)
        if self._warn[1] > 0.0 and not self._warned[1]:
            o = self._o = self.plant.outputs(x, *self._held())  # kept for outputs(): no second computation
            self._plausible(1, t + dt, o.i_s_alpha, o.i_s_beta)
        if self._warn[2] > 0.0 and not self._warned[2] and abs(x[OMEGA_M]) > self._warn[2]:
            self._warned[2] = True
            self.warnings.append(plausibility_message(2, t + dt, abs(x[OMEGA_M]), self._warn[2]))

    def _step_means(self, x0, x1, dt):
        """``(P_term, P_inv, P_chop)`` [W], the means over the step from ``x0`` to ``x1`` of ``dt`` [s]: the
        pwm inverter's energies (:attr:`PwmInverter.energies`), else the stator charge of the held voltage
        ``Q = (v_s dt - delta psi_s) / R_s`` (:meth:`PwmInverter._account`) for ``3/2 v_s . Q``; the
        chopper's from E_chop."""
        if self.inverter is not None:
            e_term, e_cond, e_sw, e_cu, e_fe = self.inverter.energies
            p_term, p_inv = e_term / dt, (e_cond + e_sw) / dt
            self._pwm_means = (e_cu / dt, e_fe / dt)
        else:
            va, vb = self._held()
            Rs = self.plant.stator_resistance(x0)
            qa = (va * dt - (x1[PSI_S_A] - x0[PSI_S_A])) / Rs
            qb = (vb * dt - (x1[PSI_S_B] - x0[PSI_S_B])) / Rs
            p_term, p_inv = 1.5 * (va * qa + vb * qb) / dt, 0.0
        p_chop = 0.0 if self._link is None else (x1[self._link.iv + 2] - x0[self._link.iv + 2]) / dt
        return p_term, p_inv, p_chop

    def powers(self, o):
        """``(P_cu_s, P_cu_r, P_fw, P_stray, P_inv, P_chop, P_in, P_mech)`` [W] at the state with its
        outputs ``o``, in the order of the outputs (:mod:`satmotor.machine.losses`)."""
        x = self.x
        p_cu_s, p_cu_r, _, p_fw, p_stray, p_mech = self.plant.powers(x, o, self._T_load)
        p_term, p_inv, p_chop = self._means
        if self.instant:
            va, vb = self._held()
            p_term, p_inv, p_chop = 1.5 * (va * o.i_s_alpha + vb * o.i_s_beta), 0.0, 0.0
        if self.inverter is not None and self.plant.R_fe > 0.0:  # pwm, core loss: P_cu_s's mean
            p_cu_s = self._pwm_means[0]
        if self.inverter is None and self.plant.lp.E_sw > 0.0:  # the average inverter's switching loss
            v_dc = self.link.V_dc if self._link is None else x[self._link.iv]
            p_inv = switching_power(self.plant.lp, self._f_sw, v_dc, phase_currents(o.i_s_alpha, o.i_s_beta))
        return p_cu_s, p_cu_r, p_fw, p_stray, p_inv, p_chop, p_term + p_inv, p_mech

    def _plausible(self, k, t, a, b):
        """|(a, b)| above bound k: the squares compared first, as the native plant does."""
        bound = self._warn[k]
        if a * a + b * b > bound * bound:
            self._warned[k] = True
            self.warnings.append(plausibility_message(k, t, math.hypot(a, b), bound))

    def _held(self):
        """The stator voltage [V] the outputs take (with R_fe the terminal current and P_fe depend on it):
        the voltage applied over the step that ended, at its end (the left limit); average inverter on a
        capacitor link: the command as the link bounds it at the step's end, else :attr:`_v` (the
        command; pwm: the step average)."""
        if self._link is not None and self.inverter is None:
            return self._link.applied(*self._v, self.x[self._link.iv])
        return self._v

    def outputs(self):
        """Output values in the order of :attr:`OUTPUTS`."""
        x, o = self.x, self._o if self._o is not None else self.plant.outputs(self.x, *self._held())
        if self._link is None:
            link = (self.link.V_dc, 0.0, 0.0, 0.0)
        else:
            iv = self._link.iv  # V_DC, E_REGEN, E_CHOP, or two places later with the thermal model
            link = (x[iv], x[iv + 1], x[iv + 2], 1.0 if self._fault else 0.0)
        p_fe = o.P_fe if self.inverter is None else self._pwm_means[1]  # pwm: its mean over the step (or 0)
        return (o.i_s_alpha, o.i_s_beta, x[PSI_S_A], x[PSI_S_B], x[PSI_R_A], x[PSI_R_B], x[OMEGA_M],
                x[THETA_M], o.T_e, o.i_mu, *link, p_fe, o.T_s, o.T_r, *self._v, *self.powers(o))

    def get_state(self):
        """The plant state, then the held stator voltage (the outputs' with R_fe and v_avg_alpha/beta;
        pwm: the step average), the held load, the step's means (:meth:`_step_means`, then pwm's P_cu_s
        and P_fe), then (pwm) the inverter's; with a capacitor link the states (motor, thermal, link), the
        chopper, the fault, then the held voltage, load and means (then the inverter's)."""
        link = (float(self._chop), float(self._fault)) if self._link is not None else ()
        held = (*self._v, self._T_load, *self._means, *self._pwm_means)  # the held voltage, load, means
        if self.inverter is None:
            return (*self.x, *link, *held)
        return (*self.x, *link, *held, *self.inverter.get_state())

    def set_state(self, state):
        state = tuple(float(v) for v in state)
        n = len(self.x)
        self.x = state[:n]
        if self._link is not None:
            self._chop, self._fault = bool(state[n]), bool(state[n + 1])
            n += 2
        self._v = state[n:n + 2]
        self._T_load = state[n + 2]
        self._means = state[n + 3:n + 6]
        self._pwm_means = state[n + 6:n + 8]
        if self.inverter is not None:
            self.inverter.set_state(state[n + 8:])
        self._o = None


# the controller's communication step rule (ControllerUnit.samples; the same in sm_controller.h)
STEP_ULPS = 8.0  # a step is n Ts when |dt - n Ts| <= STEP_ULPS eps max(n Ts, |t|, |t + dt|)
MAX_SAMPLES = 1e9  # at most this many samples in one step
STOP_REMAINDER = 1e-6  # zero samples: a step of at most this many Ts ending at the stop time (or none given)
_EPS = sys.float_info.epsilon


def samples_reason(n, Ts, max_samples):
    """Why a controller step of about ``n`` samples of ``Ts`` [s] (more than ``max_samples``) is refused
    (as the native controller: ``n`` printed as C's ``%.17g``)."""
    return (f"needs {float(n):.17g} samples of Ts = {Ts!r} s, more than max_samples = {max_samples}: take "
            "shorter communication steps or raise max_samples")


class ControllerUnit:
    """The drive controller as a co-simulation unit: n samples per step of length n Ts (:meth:`samples`).

    ``stop_time`` [s]: the host's stop time (``math.inf`` when it gave none); the FMU sets it."""

    INPUTS = tuple(v.name for v in CONTROLLER_INPUTS)
    OUTPUTS = tuple(v.name for v in CONTROLLER_OUTPUTS)

    def __init__(self, values):
        p = motor_params(values)
        f = {v.name: _number(values, v) for v in CONTROLLER_PARAMETERS}
        mode = f["mode"]
        require_choice("mode", mode, CONTROLLER_MODES)
        if f["flux_source"] == "observer" and f["use_stator_flux"]:
            raise ParameterError("use_stator_flux", True, "needs measured fluxes: not with flux_source = "
                                 "observer")
        def setting(s):  # the dataclass of setting s, its fields filled from f (Variable.fills)
            return SETTINGS[s](**{n: f[n] for n in FILLED[s]})

        dcfg = setting("drive_config")
        if mode == "pi":
            self.drive = IFOCDrive(p, setting("ifoc_gains"), f["Ts"], drive_cfg=dcfg)
        else:
            if mode == "constant_m":
                p = dataclasses.replace(p, curve=LinearCurve(p.curve.m0))
            self.drive = BacksteppingDrive(p, setting("gains"), setting("law_config"), dcfg)
        self.warnings = []  # the drive's warnings, for the host's log (the FMU glue logs and removes them)
        self.Ts = f["Ts"]
        self._V_dc = self._link = f["V_dc"]  # the parameter V_dc, the link voltage the drive now uses
        self._comp = require_number("deadtime_comp_voltage", f["deadtime_comp_voltage"], 0, inclusive=True)
        self.max_samples = require_integer("max_samples", f["max_samples"], 1)
        self._speed_estimated = f["speed_source"] == "estimated"
        self.stop_time = math.inf
        self._out = tuple(v.start for v in CONTROLLER_OUTPUTS)

    def samples(self, t, dt):
        """The number of samples a communication step from ``t`` of length ``dt`` [s] runs: ``n >= 1``
        when ``dt`` is ``n Ts`` to a few ulps (STEP_ULPS of the largest of ``n Ts``, ``|t|``,
        ``|t + dt|``: a host's time grid carries rounding of the size of its times); 0 for a remainder
        of at most STOP_REMAINDER Ts that ends at :attr:`stop_time`, or anywhere when the host declared
        no stop time (inf) (a host whose time accumulated in floating point, clipping its last step to
        its stop time: the sample at the stop time would hold its output beyond it, so none is taken,
        as a master on the exact grid takes none; OMSimulator declares no stop time; a host that goes
        on after such a step has its samples shifted by that remainder, at most 1e-6 Ts); -1 for any
        other step (refused)."""
        if dt == self.Ts:  # the common step: the rule below gives 1 too
            return 1
        x = dt / self.Ts + 0.5
        if not 0.0 <= x < MAX_SAMPLES + 1.0:  # also NaN
            return -1
        n = math.floor(x)  # the nearest whole number of samples
        tol = STEP_ULPS * _EPS * max(n * self.Ts, abs(t), abs(t + dt))
        if n >= 1 and abs(dt - n * self.Ts) <= tol:
            return n
        if n == 0 and dt <= STOP_REMAINDER * self.Ts and (
                self.stop_time == math.inf or abs(t + dt - self.stop_time) <= tol):
            return 0
        return -1

    def step(self, t, dt, inputs):
        """:meth:`samples` samples from the inputs (order of :attr:`INPUTS`), held over the step; the
        first at ``t``.  The outputs are the voltages to hold over ``[t + dt - Ts, t + dt)``.  A
        refused step, a non-finite input or a failed sample changes nothing."""
        n = self.samples(t, dt)
        if n > self.max_samples or (n < 0 and self.max_samples + 0.5 <= dt / self.Ts < math.inf):
            raise ParameterError("communicationStepSize", dt, samples_reason(
                math.floor(dt / self.Ts + 0.5), self.Ts, self.max_samples))
        if n < 0:
            raise ParameterError("communicationStepSize", dt,
                                 f"must be a whole multiple of the sample period Ts = {self.Ts!r} s")
        if self._speed_estimated:  # the omega_m input is not read: whatever it holds
            inputs = (*inputs[:MEAS_OMEGA_M], 0.0, *inputs[MEAS_OMEGA_M + 1:])
        if not math.isfinite(sum(inputs)):  # per-step fast path, as in PlantUnit.step
            _finite_inputs(self.INPUTS, inputs)
        if len(inputs) != len(self.INPUTS):  # a caller written for fewer inputs: said, not misread
            raise ParameterError("inputs", len(inputs), f"must be {len(self.INPUTS)} values, in the order "
                                 f"{', '.join(self.INPUTS)}")
        v_dc = inputs[-1]  # the link voltage: held over the step, so set once per step
        if v_dc < 0.0:
            raise ParameterError("v_dc", v_dc, "must be >= 0 (0: not connected, the parameter V_dc is used)")
        link = v_dc if v_dc > 0.0 else self._V_dc
        if link != self._link:
            self.drive.set_link_voltage(link)
            self._link = link
        if n == 1:
            self._sample(inputs)
        elif n > 1:
            before = self.get_state()
            try:
                for _ in range(n):
                    self._sample(inputs)
            except Exception:
                self.set_state(before)
                raise

    def _sample(self, inputs):
        # the first MEAS_LEN inputs are the drive's measurement tuple, in its order (MEAS_*)
        omega_ref, psi_ref, T_load = inputs[MEAS_LEN:MEAS_LEN + 3]
        d = self.drive.step(inputs[:MEAS_LEN], omega_ref, psi_ref, T_load)
        if self.drive.warnings:  # the native FMU logs the same text
            self.warnings.extend(f"BacksteppingController: {w}" for w in self.drive.warnings)
            self.drive.warnings.clear()
        if self._comp > 0.0:  # dead-time compensation from the measured currents (0: off, as before)
            va, vb = compensate(d.v_s_alpha, d.v_s_beta, inputs[MEAS_I_S_A], inputs[MEAS_I_S_B], self._comp)
            d = d._replace(v_s_alpha=va, v_s_beta=vb)
        # in the order of CONTROLLER_OUTPUTS (DRIVE_PROPERTY_OUTPUTS last)
        self._out = _SAMPLE_OUTPUTS(d) + (self.drive.omega_m_hat,) + self.drive.resistances

    def outputs(self):
        """Output values in the order of :attr:`OUTPUTS` (zeros before the first sample)."""
        return self._out

    def get_state(self):
        return tuple(float(v) for v in self._out) + self.drive.get_state()

    def set_state(self, state):
        n = len(self.OUTPUTS)
        self._out = tuple(_CAST[v.type](x) for v, x in zip(CONTROLLER_OUTPUTS, state[:n]))
        self.drive.set_state(state[n:])

"""Motor parameters (frozen dataclasses) and the default motor.

Default motor: a 4 kW, 400 V (line, rms), 50 Hz, 4-pole (n_p = 2), 1430 rpm
squirrel-cage machine.  Its resistances, leakages, inertia and friction are the
"4 kW, 400 V, 50 Hz, 1430 rpm" preset of the MATLAB/Simscape Electrical
(SimPowerSystems) Asynchronous Machine block, which is reproduced in a large part
of the induction-motor control literature.  That preset is unsaturated
(L_m = 0.1722 H); the magnetizing curve here is ours: an arctan curve whose static
inductance at the rated magnetizing current (5.7 A peak, about 0.98 Wb) equals
the preset's L_m, with the incremental inductance there 0.45 of it, i.e. the rated
flux sits in the knee.

==========  ======  ==========  =================================================
name        unit    default     source
==========  ======  ==========  =================================================
R_s         Ohm     1.405       Simscape preset 4 kW/400 V/50 Hz/1430 rpm
R_r         Ohm     1.395       same preset (referred to the stator)
l_s         H       5.839e-3    same preset, stator leakage L_ls
l_r         H       5.839e-3    same preset, rotor leakage L_lr (k = 1)
k           1       1.0         seed eq 1 (k = k_r n_r / k_s n_s); referred rotor
n_p         1       2           4-pole machine
J           kg m2   0.0131      same preset
B           N m s   2.985e-3    same preset (friction factor F)
L_m0        H       0.2772      arctan fit: m(5.7 A) = 0.1722 H, L_dyn/m = 0.45
L_m_inf     H       0.01        chosen (saturated slope, about 3.6 % of L_m0)
I_par       A       3.31        arctan fit (see L_m0)
==========  ======  ==========  =================================================

Rated data (``RatedData``): P_n = 4000 W, V_n = 400 V line rms (326.6 V phase
peak), f_n = 50 Hz, n_n = 1430 rpm (149.75 rad/s), T_n = P_n / omega_n = 26.71 N m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from satmotor.errors import ParameterError, require_choice, require_integer, require_number
from satmotor.machine.magnetics import ArctanCurve, ExponentialCurve, LinearCurve, PolynomialCurve
from satmotor.machine.table_curve import TableCurve

CURVE_NAMES = ("arctan", "exponential", "polynomial", "table", "linear")


@dataclass(frozen=True)
class MotorParams:
    """Induction motor with main-flux saturation; see the module docstring for the table.

    Parameters
    ----------
    R_s, R_r : float
        Stator and rotor resistance [Ohm].
    l_s, l_r : float
        Stator and rotor leakage inductance [H]; l_s >= 0 (0: the Gamma-equivalent model,
        :mod:`satmotor.machine.forms`), l_r > 0.
    k : float
        Turns ratio k = k_r n_r / (k_s n_s) [1] (seed eq 1).
    n_p : int
        Pole pairs [1].
    J : float
        Rotor and load inertia [kg m2].
    B : float
        Viscous friction [N m s], >= 0.
    curve : magnetizing characteristic
        One of the curves of :mod:`satmotor.machine.magnetics` / :mod:`satmotor.machine.table_curve`.
    """

    R_s: float = 1.405
    R_r: float = 1.395
    l_s: float = 5.839e-3
    l_r: float = 5.839e-3
    k: float = 1.0
    n_p: int = 2
    J: float = 0.0131
    B: float = 2.985e-3
    curve: object = field(default_factory=ArctanCurve)

    def __post_init__(self):
        for name in ("R_s", "R_r", "l_s", "l_r", "k", "J"):
            # l_s = 0: the Gamma-equivalent model
            require_number(name, getattr(self, name), 0, inclusive=name == "l_s")
        require_integer("n_p", self.n_p, 1)
        require_number("B", self.B, 0, inclusive=True)
        if not hasattr(self.curve, "solve"):
            raise ParameterError("curve", self.curve, "must be a magnetizing curve object")

    @property
    def sigma(self):
        """sigma = 1 + k^2 l_s / l_r [1] (errata notation)."""
        return 1.0 + self.k * self.k * self.l_s / self.l_r

    @property
    def l_e(self):
        """Parallel leakage l_e = 1 / (1/l_s + k^2/l_r) [H]; 0 for l_s = 0 (the Gamma model)."""
        if self.l_s == 0.0:
            return 0.0
        return 1.0 / (1.0 / self.l_s + self.k * self.k / self.l_r)

    @property
    def kappa(self):
        """Torque factor kappa = 3/2 n_p [1] (amplitude-invariant transform)."""
        return 1.5 * self.n_p


class SupplyMixin:
    """What a name plate's ``V_n`` [V] line-to-line rms and ``f_n`` [Hz] give (shared by
    :class:`RatedData` and :class:`satmotor.machine.library.Nameplate`)."""

    @property
    def V_phase_peak(self):
        """Phase voltage amplitude [V] = V_n sqrt(2/3) (space-vector magnitude)."""
        return self.V_n * math.sqrt(2.0 / 3.0)

    @property
    def omega_e(self):
        """Supply angular frequency [rad/s]."""
        return 2.0 * math.pi * self.f_n


@dataclass(frozen=True)
class RatedData(SupplyMixin):
    """Name-plate data of the default motor (SI)."""

    P_n: float = 4000.0  # [W] rated shaft power
    V_n: float = 400.0  # [V] line-to-line rms
    f_n: float = 50.0  # [Hz]
    n_n: float = 1430.0  # [rpm]
    I_mu_n: float = 5.7  # [A] peak rated magnetizing current (design point of the curve)

    @property
    def omega_n(self):
        """Rated mechanical speed [rad/s]."""
        return self.n_n * math.pi / 30.0

    @property
    def T_n(self):
        """Rated torque [N m]."""
        return self.P_n / self.omega_n


def make_curve(name, L_m0=0.2772, L_m_inf=0.01, I_par=3.31, poly_b=2.46, poly_n=7, table_file=""):
    """Build a magnetizing curve from its family name and the flat parameter set the FMUs expose.

    Raises :class:`ParameterError` naming ``curve`` or the offending coefficient.
    """
    require_choice("curve", name, CURVE_NAMES)
    if name == "arctan":
        return ArctanCurve(L_m0, L_m_inf, I_par)
    if name == "exponential":
        return ExponentialCurve(L_m0, L_m_inf, I_par)
    if name == "polynomial":
        return PolynomialCurve(L_m0, poly_b, poly_n)
    if name == "linear":
        return LinearCurve(L_m0)
    if not table_file:  # the table curve
        raise ParameterError("table_file", table_file, "is required when curve = 'table'")
    return TableCurve.from_csv(table_file)

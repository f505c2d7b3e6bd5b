"""Plant-only loss extensions: the core-loss resistance R_fe and the two-body thermal model.

Core loss (``R_fe`` [Ohm], 0: none)
-----------------------------------
R_fe sits across the stator emf ``e_s = v_s - R_s i_s = d psi_s/dt`` (behind R_s, ahead of the stator
leakage: the Gamma placement; for l_s = 0 exactly across the magnetizing branch).  With ``i_s0`` the
current the fluxes give (the current through the leakage and the air gap), the terminal current is
``i_s = i_s0 + i_fe``, ``i_fe = e_s / R_fe``, so::

    d psi_s/dt = e_s = R_fe (v_s - R_s i_s0) / (R_fe + R_s),   i_fe = (v_s - R_s i_s0) / (R_fe + R_s)
    T_e = 3/2 n_p (psi_s x i_s0)            (the core branch makes no torque)
    P_fe = 3/2 |e_s|^2 / R_fe  [W]

Thermal model (two bodies, ``ThermalParams``)
---------------------------------------------
Stator (copper, core) and rotor (cage) temperatures T_s, T_r [K]::

    C_th_s dT_s/dt = P_cu_s + P_fe - (T_s - T_amb)/R_th_s - (T_s - T_r)/R_th_sr
    C_th_r dT_r/dt = P_cu_r        - (T_r - T_amb)/R_th_r + (T_s - T_r)/R_th_sr
    P_cu_s = 3/2 R_s(T_s) |i_s|^2,  P_cu_r = 3/2 R_r(T_r) |i_r|^2
    R_s(T) = R_s (1 + alpha_s (T - T_ref)),  R_r(T) = R_r (1 + alpha_r (T - T_ref))

(friction heat is not fed back: it leaves through the bearings and the fan).  With ``thermal`` off
the temperatures stay at T_s0, T_r0 and the resistances are R_s(T_s0), R_r(T_r0), constant: with the
defaults (T_s0 = T_r0 = T_ref) exactly R_s and R_r, today's plant bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

from satmotor.errors import ParameterError, require_number

T_20C = 293.15  # [K]
# temperature coefficients at 20 C, IEC 60287-1-1 (Table 1): copper 3.93e-3, aluminium 4.03e-3 1/K
# (inferred zero-resistance temperatures 234.5 and 228 C below 0 C); IEC 60034-1's resistance correction
# uses 235 and 225, i.e. 3.92e-3 and 4.08e-3 at 20 C
ALPHA_COPPER = 3.93e-3  # [1/K] the stator winding
ALPHA_ALUMINIUM = 4.03e-3  # [1/K] the cage (die-cast aluminium; an alloy is somewhat lower)


@dataclass(frozen=True)
class ThermalParams:
    """The two-body thermal model (module docstring); temperatures [K], capacities [J/K], thermal
    resistances [K/W], temperature coefficients [1/K].

    Defaults: the default 4-kW TEFC motor, an estimate (docs/motors.md): stator 12 kg of iron and
    copper (C_th_s = 6000 J/K), rotor 5 kg (C_th_r = 2200 J/K); at rated load (losses about
    300 W stator, 160 W rotor) a stator rise of about 80 K; time constants of tens of minutes.
    """

    thermal: bool = False
    T_amb: float = T_20C
    T_s0: float = T_20C
    T_r0: float = T_20C
    T_ref: float = T_20C
    alpha_s: float = ALPHA_COPPER
    alpha_r: float = ALPHA_ALUMINIUM
    C_th_s: float = 6000.0
    C_th_r: float = 2200.0
    R_th_s: float = 0.2
    R_th_r: float = 0.5
    R_th_sr: float = 0.15

    def __post_init__(self):
        if not isinstance(self.thermal, bool):
            raise ParameterError("thermal", self.thermal, "must be a Boolean")
        for name in ("T_amb", "T_s0", "T_r0", "T_ref", "C_th_s", "C_th_r", "R_th_s", "R_th_r", "R_th_sr"):
            require_number(name, getattr(self, name), 0)
        for name in ("alpha_s", "alpha_r"):
            require_number(name, getattr(self, name), 0, inclusive=True)
        for name, a, T in (("T_s0", self.alpha_s, self.T_s0), ("T_r0", self.alpha_r, self.T_r0)):
            if not 1.0 + a * (T - self.T_ref) > 0.0:
                raise ParameterError(name, T, "gives a resistance <= 0 (1 + alpha (T - T_ref) <= 0)")


def resistance(R, alpha, T, T_ref):
    """``R (1 + alpha (T - T_ref))`` [Ohm]: with T == T_ref exactly R."""
    return R * (1.0 + alpha * (T - T_ref))

"""Every loss of the drive (issue 35): the parameters of the mechanical and inverter losses and the
power outputs' formulas, written once (the C core's ``sm_losses.c`` is the same floats).

Mechanical losses (they act on the shaft: ``Plant._rates`` subtracts their torque, so energy is
conserved; all zero by default, then the mechanics exactly as before)::

    T_fw    = T_fric sign(omega_m) + k_wind omega_m |omega_m|       friction and windage [N m]
    T_stray = k_stray |i_s0|^2 omega_m                               stray load [N m]
    P_fw    = (B omega_m + T_fric sign(omega_m) + k_wind omega_m |omega_m|) omega_m   [W]
    P_stray = T_stray omega_m = k_stray |i_s0|^2 omega_m^2                              [W]

(``B`` the motor's viscous friction, a friction loss too; ``i_s0`` the stator current through the
leakage, the terminal current without R_fe; the stray law is the Modelica library's
``StrayLoad`` with ``power_w = 1``: ``P_ref (I/I_ref)^2 (omega/omega_ref)^2``, the frequency that of
the shaft.)  The copper losses are ``P_cu_s = 3/2 R_s(T_s) |i_s|^2`` (the terminal current),
``P_cu_r = 3/2 R_r(T_r) |i_r|^2``, the core loss ``P_fe = 3/2 |e_s|^2 / R_fe``
(:mod:`satmotor.machine.thermal`).  ``P_mech = (T_load + B_2 omega_m |omega_m|) omega_m``: the power
the shaft delivers to the load (the fan term ``B_2`` is the load's).

Inverter (``E_sw`` [J] the datasheet's ``E_on + E_off`` at ``V_sw_ref`` [V] and ``I_sw_ref`` [A];
0: no switching loss).  An edge of leg ``j`` (one device off, the other on) dissipates
``E_sw / 2 (v_dc / V_sw_ref) (|i_j| / I_sw_ref)``, ``i_j`` the phase current at the edge: the pwm
inverter adds it at every edge it switches; the average inverter dissipates the same per carrier
period (two edges per leg) as a power ``f_sw E_sw (v_dc / V_sw_ref) sum_j |i_j| / I_sw_ref``.  The
conduction loss is the on-state drops' (pwm): ``-3/2 delta . i_s`` (:mod:`satmotor.converter.pwm_link`).
``P_inv`` is conduction plus switching, ``P_in`` the power drawn from the DC link, ``3/2 v_s . i_s``
plus ``P_inv``.
"""

from __future__ import annotations

from dataclasses import dataclass

from satmotor.errors import require_number

# the loss parameters, in their order (checked in it, Python and C)
LOSS_NAMES = ("T_fric", "k_wind", "k_stray", "E_sw", "V_sw_ref", "I_sw_ref")


@dataclass(frozen=True)
class LossParams:
    """The mechanical and inverter loss parameters (module docstring); zero losses by default.

    T_fric [N m] >= 0, k_wind [N m s2/rad2] >= 0, k_stray [N m s/(A2 rad)] >= 0, E_sw [J] >= 0,
    V_sw_ref [V] > 0, I_sw_ref [A] > 0."""

    T_fric: float = 0.0
    k_wind: float = 0.0
    k_stray: float = 0.0
    E_sw: float = 0.0
    V_sw_ref: float = 600.0
    I_sw_ref: float = 10.0

    def __post_init__(self):
        for name in LOSS_NAMES[:4]:
            require_number(name, getattr(self, name), 0, inclusive=True)
        for name in LOSS_NAMES[4:]:
            require_number(name, getattr(self, name), 0)

    @property
    def mechanical(self):
        """Whether a friction, windage or stray torque acts (then :func:`loss_torque` is applied)."""
        return self.T_fric > 0.0 or self.k_wind > 0.0 or self.k_stray > 0.0

    @property
    def k_edge(self):
        """[J/(V A)] the energy of one edge per volt and ampere: ``E_sw / 2 / (V_sw_ref I_sw_ref)``."""
        return 0.5 * self.E_sw / (self.V_sw_ref * self.I_sw_ref)


def friction_torque(lp, w):
    """``T_fric sign(w) + k_wind w |w|`` [N m] at the speed ``w`` [rad/s] (without the viscous B)."""
    f = lp.T_fric if w > 0.0 else -lp.T_fric if w < 0.0 else 0.0
    return f + lp.k_wind * w * abs(w)


def loss_torque(lp, w, i2):
    """The friction, windage and stray torque [N m] opposing ``w`` [rad/s] with ``|i_s0|^2 = i2``
    [A2]."""
    return friction_torque(lp, w) + lp.k_stray * i2 * w


def switching_power(lp, f_sw, v_dc, cur):
    """The average inverter's switching loss [W]: ``2 f_sw k_edge v_dc sum |i_j|`` for the phase
    currents ``cur`` [A] on the link voltage ``v_dc`` [V]."""
    return 2.0 * f_sw * lp.k_edge * v_dc * (abs(cur[0]) + abs(cur[1]) + abs(cur[2]))

"""The DC link inside the plant: a capacitor between the source and a lossless average-value inverter,
with a brake chopper and an over-voltage fault (SI units).

``dc_link = ideal`` (the default) is today's plant: the link is a constant voltage ``V_dc`` [V] that
bounds nothing (the commanded stator voltage is applied as it is) and only reported.

``dc_link = capacitor``: the link voltage ``v_dc`` [V] is a plant state, integrated with the motor's six
states by the same RK4 and sub-steps (:meth:`DCLink.step`)::

    C_dc d v_dc/dt = i_src - i_dc - i_chop
    i_dc   = 3/2 v_s . i_s / v_dc               (lossless inverter, amplitude-invariant Clarke)

``i_s`` is the terminal current at the applied voltage: with core loss (``R_fe > 0``) it includes the
core branch's current, so the link feeds the core loss too.  With the thermal model on, the motor's
state has its two temperatures after the six (``plant.T_S``, ``plant.T_R``) and the link's three states
follow them (:attr:`DCLink.iv`: 6, or 8 with the thermal model); they integrate together by one RK4.
    i_src  = max(0, (v_source(t) - v_dc) / R_src)   (a diode: no regeneration into the source)
    i_chop = v_dc / R_chop while the chopper is on, else 0

* ``v_source``: ``dc_source = dc``: the constant ``V_dc``; ``dc_source = rectifier``: the six-pulse
  envelope of a three-phase grid of ``V_grid`` [V] line-to-line rms at ``f_grid`` [Hz],
  ``sqrt(2) V_grid cos(phi)``, ``phi = theta - (pi/3) floor(theta / (pi/3)) - pi/6`` in
  ``[-pi/6, pi/6)``, ``theta = 2 pi f_grid t`` (an ideal diode bridge: the largest line-to-line
  voltage, rectified; no grid inductance, ``R_src`` the whole source resistance).
* The voltage applied to the motor: the commanded ``v_s = (v_s_alpha, v_s_beta)`` as it is while
  ``|v_s| <= v_dc / sqrt(3)`` (the largest voltage a space-vector modulator gives), else scaled onto
  that circle (a real modulator uses the measured link voltage); ``v_dc <= 0`` applies 0.  Within an
  RK4 stage the stage's own ``v_dc`` bounds it.
* The chopper (``R_chop > 0``) switches at the ends of the RK4 sub-steps, with hysteresis: on when
  ``v_dc > V_chop_on``, off when ``v_dc < V_chop_off``, held over each sub-step (a piecewise-smooth
  right-hand side for RK4).  ``R_chop = 0``: no chopper.
* Over-voltage: ``v_dc > V_dc_max`` at a sub-step end latches the fault ``dc_fault`` (reported, the
  physics goes on); ``V_dc_max = 0``: no check.
* Integrated with the states: ``E_regen`` [J], the energy the motor returned into the link
  (``int max(0, -3/2 v_s . i_s) dt``), and ``E_chop`` [J], the energy dissipated in the chopper
  (``int v_dc i_chop dt``).

The C port is ``fmu/native/core/sm_dclink.c`` (the same floats).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from satmotor.errors import ParameterError, require_choice, require_number
from satmotor.machine.integrate import rk4

DC_LINK_MODES = ("ideal", "capacitor")
DC_SOURCES = ("dc", "rectifier")
# the link's states after the motor's six (plant.PSI_S_A .. THETA_M); with the thermal model on they
# follow T_s, T_r: two places later (DCLink.iv, the one place the offset is derived)
V_DC, E_REGEN, E_CHOP = 6, 7, 8
N_LINK_STATES = 3
_SQRT3 = math.sqrt(3.0)


def is_capacitor(dc_link):
    """Whether the plant parameter ``dc_link`` (its value; None: absent, the default ``ideal``) puts the
    capacitor link on: the one test of it (:attr:`DCLinkParams.capacitor`; the scenario's wiring, metrics
    and reference loop, :func:`orchestration.scenario.system.link_on`).  The C core's is
    ``sm_dclink.capacitor``, set once by ``sm_dclink_init`` from the parsed choice."""
    return dc_link == "capacitor"


@dataclass(frozen=True)
class DCLinkParams:
    """The DC link's parameters (see the module docstring).

    ``V_dc`` [V] > 0: ideal: the link voltage; capacitor: the initial link voltage and the ``dc``
    source's voltage (its default is the controller's default ``ControllerConfig.V_dc``, 540 V: the
    average of a six-pulse bridge on a 400 V grid).  ``C_dc`` [F] > 0, ``R_src`` [Ohm] > 0,
    ``V_grid`` [V] > 0 (line-to-line rms), ``f_grid`` [Hz] > 0, ``R_chop`` [Ohm] >= 0 (0: no chopper),
    ``V_chop_off`` [V] < ``V_chop_on`` [V] (both > 0, checked also without a chopper), ``V_dc_max`` [V]
    >= 0 (0: no over-voltage check), above ``V_chop_on`` when both the chopper and the check are on.
    """

    dc_link: str = "ideal"
    V_dc: float = 540.0
    C_dc: float = 470e-6
    dc_source: str = "dc"
    R_src: float = 0.1
    V_grid: float = 400.0
    f_grid: float = 50.0
    V_chop_on: float = 750.0
    V_chop_off: float = 720.0
    R_chop: float = 0.0
    V_dc_max: float = 800.0

    def __post_init__(self):
        require_choice("dc_link", self.dc_link, DC_LINK_MODES)
        require_choice("dc_source", self.dc_source, DC_SOURCES)
        for name in ("V_dc", "C_dc", "R_src", "V_grid", "f_grid"):
            require_number(name, getattr(self, name), 0)
        require_number("R_chop", self.R_chop, 0, inclusive=True)
        require_number("V_dc_max", self.V_dc_max, 0, inclusive=True)
        # the chopper's thresholds are checked without a chopper too (R_chop = 0): an inverted
        # hysteresis is never accepted silently, to surface when R_chop is set (issue 31)
        require_number("V_chop_on", self.V_chop_on, 0)
        require_number("V_chop_off", self.V_chop_off, 0)
        if not self.V_chop_off < self.V_chop_on:
            raise ParameterError("V_chop_off", self.V_chop_off,
                                 f"must be below V_chop_on = {self.V_chop_on!r} V (the hysteresis: the "
                                 "chopper switches on above V_chop_on and off below V_chop_off)")
        if self.R_chop > 0.0 and self.V_dc_max > 0.0 and not self.V_chop_on < self.V_dc_max:
            raise ParameterError("V_dc_max", self.V_dc_max, CHOPPER_BELOW_FAULT.format(self.V_chop_on))

    @property
    def capacitor(self):
        return is_capacitor(self.dc_link)


#: the reason of a fault level at or below the chopper's (C: sm_dclink.c, the same text)
CHOPPER_BELOW_FAULT = ("must be above V_chop_on = {!r} V with a brake chopper (R_chop > 0): the chopper "
                       "switches on below the over-voltage fault's level (V_dc_max = 0: no fault check)")


def over_voltage_message(t, v_dc, V_dc_max):
    """The fault's warning (logged once per run), as the native plant writes it."""
    return (f"SaturatedInductionMotor: DC-link over-voltage at t = {t!r} s: v_dc = {v_dc!r} V exceeds "
            f"V_dc_max = {V_dc_max!r} V; dc_fault is set and the simulation goes on (logged once per run)")


class DCLink:
    """The capacitor link bound to a :class:`~satmotor.machine.plant.Plant` (``dc_link = capacitor``).

    The state is the plant's (six, or eight with the thermal model) followed by ``(v_dc, E_regen,
    E_chop)`` at :attr:`iv`, ``iv + 1``, ``iv + 2``; the chopper's on/off state and the latched fault are
    held in :meth:`step`'s arguments and results."""

    __slots__ = ("plant", "p", "iv", "_src_dc", "_V_src", "_inv_R_src", "_inv_C", "_chop", "_inv_R_chop",
                 "_amp", "_omega_g", "_third", "_sixth")

    def __init__(self, plant, params):
        self.plant = plant
        self.p = params
        self.iv = V_DC + len(plant.thermal_state())  # v_dc's place: after the motor's states
        self._src_dc = params.dc_source == "dc"
        self._V_src = params.V_dc
        self._inv_R_src = 1.0 / params.R_src
        self._inv_C = 1.0 / params.C_dc
        self._chop = params.R_chop > 0.0
        self._inv_R_chop = 1.0 / params.R_chop if self._chop else 0.0
        self._amp = math.sqrt(2.0) * params.V_grid
        self._omega_g = 2.0 * math.pi * params.f_grid
        self._third = math.pi / 3.0
        self._sixth = math.pi / 6.0

    def initial_state(self, x_motor):
        """The motor's state followed by the link's: ``v_dc = V_dc``, no energy yet."""
        return (*x_motor, self.p.V_dc, 0.0, 0.0)

    def source_voltage(self, t):
        """``v_source(t)`` [V]: ``V_dc``, or the six-pulse envelope ``sqrt(2) V_grid cos(phi)``."""
        if self._src_dc:
            return self._V_src
        theta = self._omega_g * t
        phi = theta - self._third * math.floor(theta / self._third) - self._sixth
        return self._amp * math.cos(phi)

    @staticmethod
    def applied(v_a, v_b, v_dc):
        """The stator voltage [V] the inverter applies: the command, scaled onto ``|v| = v_dc/sqrt(3)``
        beyond it; 0 for ``v_dc <= 0``."""
        if not v_dc > 0.0:
            return 0.0, 0.0
        vmax = v_dc / _SQRT3
        vn = math.hypot(v_a, v_b)
        if vn > vmax:
            g = vmax / vn
            return v_a * g, v_b * g
        return v_a, v_b

    def rates(self, t, v_dc, p_inv, chop):
        """``(d v_dc/dt, d E_regen/dt, d E_chop/dt)`` [V/s, W, W] at link voltage ``v_dc`` [V] with the
        power ``p_inv`` [W] drawn by the inverter and the chopper state ``chop`` (bool): the link's
        equations of the module docstring, for the average inverter and the pwm one alike
        (:mod:`satmotor.converter.pwm_link`)."""
        i_dc = p_inv / v_dc if v_dc > 0.0 else 0.0
        i_src = (self.source_voltage(t) - v_dc) * self._inv_R_src
        if not i_src > 0.0:
            i_src = 0.0
        i_chop = v_dc * self._inv_R_chop if chop else 0.0
        return (i_src - i_dc - i_chop) * self._inv_C, -p_inv if p_inv < 0.0 else 0.0, v_dc * i_chop

    def derivatives(self, t, x, v_a, v_b, T_load, chop):
        """``dx/dt`` of the nine states for the command ``(v_a, v_b)`` [V], ``T_load`` [N m] and the
        chopper state ``chop`` (bool) held; ``p_inv = 3/2 v_s . i_s`` is the power into the motor (``i_s``
        the terminal current at the applied voltage: with R_fe it includes the core branch's)."""
        n = self.iv
        v_dc = x[n]
        va, vb = self.applied(v_a, v_b, v_dc)
        o = self.plant.outputs(x[:n], va, vb)
        p_inv = 1.5 * (va * o.i_s_alpha + vb * o.i_s_beta)
        d = self.plant.derivatives(t, x[:n], va, vb, T_load)
        return (*d, *self.rates(t, v_dc, p_inv, chop))

    def switch(self, v_dc, chop):
        """The chopper's state after a sub-step ending at ``v_dc`` [V] (hysteresis)."""
        if not self._chop:
            return False
        if v_dc > self.p.V_chop_on:
            return True
        if v_dc < self.p.V_chop_off:
            return False
        return chop

    def step(self, t, x, v_a, v_b, T_load, h, n_sub, chop, fault):
        """Advance the nine states over ``h`` [s] in ``n_sub`` RK4 sub-steps (times ``t + j h/n_sub``,
        as :func:`~satmotor.machine.integrate.rk4`); the chopper switches and the fault latches at the
        sub-step ends.  Returns ``(x, chop, fault, t_fault)``: ``t_fault`` [s] the sub-step end where the
        fault was first set in this call (None otherwise)."""
        dt = h / n_sub
        t_fault = None
        iv = self.iv
        for j in range(n_sub):
            tj = t + j * dt
            x = rk4(self.derivatives, tj, x, dt, 1, (v_a, v_b, T_load, chop))
            chop, fault, t_fault = self.substep_end(x[iv], tj + dt, chop, fault, t_fault)
        return x, chop, fault, t_fault

    def substep_end(self, v_dc, t_end, chop, fault, t_fault):
        """At a sub-step's end ``t_end`` [s] with link voltage ``v_dc`` [V]: the chopper's new state
        (:meth:`switch`) and the over-voltage fault latched, ``t_fault`` set where it is first set:
        ``(chop, fault, t_fault)``."""
        chop = self.switch(v_dc, chop)
        V_max = self.p.V_dc_max
        if not fault and V_max > 0.0 and v_dc > V_max:
            return chop, True, t_end
        return chop, fault, t_fault

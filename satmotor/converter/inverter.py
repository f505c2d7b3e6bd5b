"""The plant's voltage source inverter: average-value (today's ideal voltages) or carrier-comparison PWM.

``average``: the plant applies the commanded alpha/beta voltage as it is (the average-value model).

``pwm``: a two-level, three-leg inverter on a DC link of voltage ``V_dc`` [V], the star point of the
machine floating.  Everything below is on the absolute time axis ``t`` [s]:

* **Carrier**: symmetric triangle of frequency ``f_sw`` [Hz], aligned with t = 0: a valley at every
  ``t = 2 j T_h`` and a peak at every ``t = (2 j + 1) T_h`` with ``T_h = 0.5 / f_sw`` the half carrier
  period.  Half period ``k`` is ``[k T_h, (k + 1) T_h)``: rising (valley to peak) for even ``k``,
  falling for odd ``k``.
* **Modulator** (regular sampling, double update): at the start of each half period (a peak or a
  valley) the duty cycles are taken from the commanded voltage ``(v_s_alpha, v_s_beta)`` held at that
  instant: phase references ``v_a = v_alpha``, ``v_b,c = -v_alpha/2 +- sqrt(3)/2 v_beta``, min-max
  zero-sequence injection ``v_0 = -(max + min) / 2``, duty ``d = 1/2 + (v_x + v_0) / V_dc`` clipped to
  [0, 1] (the linear range is the circle ``|v_s| <= V_dc / sqrt(3)``).  A leg is high (upper device,
  ``+V_dc/2`` against the link's midpoint) while the carrier (0 at a valley, 1 at a peak) is below
  ``d``: in a rising half ``[k T_h, k T_h + d T_h)``, in a falling one ``[k T_h + (1 - d) T_h,
  (k + 1) T_h)``.  Over a half period with zero dead time and zero drops the leg averages
  ``(d - 1/2) V_dc = v_x + v_0`` and the floating star point removes ``v_0``: the average is the
  command (the exactness the tests check).
* **Dead time** ``t_dead`` [s]: at every edge of a leg's ideal switching function the turning-on
  device is delayed by ``t_dead``: over ``[edge, edge + t_dead)`` (cut short by the leg's next edge)
  both devices are off and a diode conducts, chosen by the sign of that phase current at the start of
  the interval (from the state there): positive (out of the leg) -> lower diode -> ``-V_dc/2``,
  negative -> upper diode -> ``+V_dc/2``, exactly zero -> the new state's voltage (no error; at rest
  the currents are zero).  Approximation: if the current crosses zero inside the dead interval, the
  diode chosen at its start is taken to conduct to its end (the real leg would clamp the current at
  zero and follow the other diode).  To first order the average phase error is
  ``-sign(i) t_dead f_sw V_dc`` (one lost ``t_dead V_dc`` per carrier period).
* **On-state drop** ``v_on`` [V] of a conducting device or diode: every constant interval's phase
  voltage less ``sign(i) v_on``, the sign of the phase current at the interval's start.
* **Integration**: within a communication step the plant integrates the piecewise-constant
  alpha/beta voltage (``v_alpha = (2 v_a - v_b - v_c) / 3``, ``v_beta = (v_b - v_c) / sqrt(3)``) to
  the switching instants (edges and dead-interval ends), each constant interval of length ``L`` by
  the plant's RK4 with ``max(1, ceil(L / h_int - 1e-9))`` equal sub-steps.  **Merging**: an event
  closer than ``eps = MERGE_REL T_h`` after the start of the current interval is applied at that
  start (so no interval is shorter than eps; the event moves earlier by less than eps, a
  voltage-second error below ``eps V_dc``); an event within eps before the step's end is left to the
  next step, which applies it at its start.  An edge that changes nothing (a leg held across a
  half-period boundary) does not split an interval.  An edge belongs to the step ``[t0, t1)`` with
  ``t0 - eps <= edge < t1 - eps``; a half period's duty cycles are computed once (when it is first
  reached) and kept until the next half period, across step boundaries.

With core loss or the thermal model the plant's states (eight with the thermal model) integrate over
each interval alike; the phase currents that choose the dead-interval diode and the drops' signs are the
plant's outputs at zero voltage, whose signs are those of the current through the stator leakage (the
terminal current less the core branch's, which follows the voltage instantly: at zero voltage the
terminal current is that current times R_fe / (R_fe + R_s)).  On a capacitor link (``link``) each
interval integrates the link's voltage with the motor: :mod:`satmotor.converter.pwm_link`.

The C core's ``fmu/native/core/sm_inverter.c`` is the same algorithm (the same floats).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from satmotor.converter import pwm_link
from satmotor.errors import ParameterError, require_choice, require_number
from satmotor.machine.phases import SQRT3_2 as _SQRT3_2
from satmotor.machine.phases import alpha_beta, phase_currents

INVERTERS = ("average", "pwm")
MERGE_REL = 1e-6  # [1] events closer than MERGE_REL T_h are merged (module docstring)
EVENTS_PER_HALF = 12  # at most 2 edges and 2 dead-interval ends per leg and half period
_INF = math.inf


@dataclass(frozen=True)
class InverterParams:
    """The plant's inverter (SI).  ``V_dc`` [V] has no default here: the plant's is the controller's
    default link voltage (:mod:`satmotor.interface`, one number).

    inverter 'average' (ideal voltages) or 'pwm'; f_sw [Hz] carrier frequency (> 0); t_dead [s] dead
    time, 0 <= t_dead < 1 / (2 f_sw); v_on [V] device on-state drop, 0 <= v_on < V_dc / 2.
    """

    V_dc: float
    inverter: str = "average"
    f_sw: float = 5000.0
    t_dead: float = 0.0
    v_on: float = 0.0

    def __post_init__(self):
        require_choice("inverter", self.inverter, INVERTERS)
        require_number("V_dc", self.V_dc, 0)
        require_number("f_sw", self.f_sw, 0)
        require_number("t_dead", self.t_dead, 0, inclusive=True)
        if not self.t_dead < 0.5 / self.f_sw:
            raise ParameterError("t_dead", self.t_dead, f"must be less than half the carrier period "
                                 f"1/(2 f_sw) = {0.5 / self.f_sw!r} s")
        require_number("v_on", self.v_on, 0, inclusive=True)
        if not self.v_on < 0.5 * self.V_dc:
            raise ParameterError("v_on", self.v_on, f"must be less than V_dc/2 = {0.5 * self.V_dc!r} V")


def duties(v_alpha, v_beta, V_dc):
    """Duty cycles ``(d_a, d_b, d_c)`` in [0, 1] of the command [V] on a link of ``V_dc`` [V]: min-max
    zero-sequence injection, clipped."""
    a = v_alpha
    b = -0.5 * v_alpha + _SQRT3_2 * v_beta
    c = -0.5 * v_alpha - _SQRT3_2 * v_beta
    hi = a if a > b else b
    hi = hi if hi > c else c
    lo = a if a < b else b
    lo = lo if lo < c else c
    z = -0.5 * (hi + lo)
    out = []
    for v in (a, b, c):
        d = 0.5 + (v + z) / V_dc
        out.append(0.0 if d < 0.0 else 1.0 if d > 1.0 else d)
    return tuple(out)



def leg_volts(legs, half):
    """``(v_alpha, v_beta, v_a, v_b, v_c)`` [V] of the legs ``(sig, dl)`` (:meth:`PwmInverter._legs`) with
    ``half`` [V] half the link's voltage: phase voltages ``sig[j] half + dl[j]``, the star point floating."""
    sig, dl = legs
    v = [sig[0] * half + dl[0], sig[1] * half + dl[1], sig[2] * half + dl[2]]
    return (*alpha_beta(v[0], v[1], v[2]), v[0], v[1], v[2])

def half_edges(k, T_h, d):
    """The ideal edges of half period ``k`` [(time [s], order, phase, new state)] sorted: the state at
    its start (time ``k T_h``, order = phase) and the mid-half edge (order 3 + phase) of each leg."""
    ts = k * T_h
    out = []
    even = k % 2 == 0
    for x in range(3):
        dx = d[x]
        if even:
            out.append((ts, x, x, 1 if dx > 0.0 else 0))
            if 0.0 < dx < 1.0:
                out.append((ts + dx * T_h, 3 + x, x, 0))
        else:
            out.append((ts, x, x, 0 if dx < 1.0 else 1))
            if 0.0 < dx < 1.0:
                out.append((ts + (1.0 - dx) * T_h, 3 + x, x, 1))
    out.sort()
    return out


class PwmInverter:
    """The ``pwm`` inverter of one plant: its settings and switching state (see the module docstring).

    State (:meth:`get_state`, floats): whether a half period's duties are held and which (``k``), the
    duties, each leg's ideal state (or unknown before the first step), dead flags, their ends [s] and
    voltages [V]."""

    N_STATE = 17

    def __init__(self, params, losses=None):
        self.params = params
        self.f_sw, self.t_dead, self.v_on = params.f_sw, params.t_dead, params.v_on
        self.T_h = 0.5 / params.f_sw
        self.eps = MERGE_REL * self.T_h
        self._V_dc = params.V_dc
        self.k_edge = 0.0 if losses is None else losses.k_edge  # [J/(V A)] an edge's energy per V and A
        self.energies = (0.0,) * 5  # the last step's (E_term, E_cond, E_sw, E_cu_s, E_fe) [J] (:meth:`step`)
        self.reset()

    def reset(self):
        self.have = False  # duties of half period self.k held
        self.k = 0
        self.d = [0.5, 0.5, 0.5]
        self.s = [-1, -1, -1]  # ideal leg states; -1: unknown (before the first step)
        self.dead = [False, False, False]
        self.dead_until = [0.0, 0.0, 0.0]
        self.dead_v = [0.0, 0.0, 0.0]

    def link_voltage(self):
        """The DC-link voltage [V] the inverter switches (the one place the plant reads it)."""
        return self._V_dc

    def get_state(self):
        return (float(self.have), float(self.k), *self.d, *(float(s) for s in self.s),
                *(float(b) for b in self.dead), *self.dead_until, *self.dead_v)

    def set_state(self, st):
        st = [float(v) for v in st]
        self.have, self.k = st[0] != 0.0, int(st[1])
        self.d = st[2:5]
        self.s = [int(v) for v in st[5:8]]
        self.dead = [v != 0.0 for v in st[8:11]]
        self.dead_until = st[11:14]
        self.dead_v = st[14:17]

    def intervals_bound(self, dt):
        """An upper bound of the constant intervals of a step of ``dt`` [s]."""
        return EVENTS_PER_HALF * (math.ceil(dt / self.T_h) + 1) + 1

    def step(self, plant, t0, x, v_alpha, v_beta, T_load, dt, h_int, trace=None, link=None, chop=False,
             fault=False):
        """Advance the plant state ``x`` from ``t0`` over ``dt`` [s] with the command held; returns
        ``(x, v_avg_alpha, v_avg_beta)``, the step averages [V] of the applied alpha/beta voltage.
        ``trace``: a list that receives ``(t_start, length, v_alpha, v_beta, v_a, v_b, v_c)`` of every
        constant interval integrated (on a capacitor link: its voltages at the interval's start).
        ``link``: None (the ideal link), or the :class:`~satmotor.converter.dc_link.DCLink` whose state
        ``x`` is (:mod:`~satmotor.converter.pwm_link`), with the chopper's state ``chop`` and the latched
        ``fault``; then :attr:`link_out` is ``(chop, fault, t_fault)`` after the step.  :attr:`energies`:
        the step's ``(E_term, E_cond, E_sw, E_cu_s, E_fe)`` [J], the energy into the motor's terminals,
        the on-state drops', the edges', the stator copper's and the core's (:meth:`_account`,
        :mod:`satmotor.machine.losses`)."""
        T_h, eps, t_dead = self.T_h, self.eps, self.t_dead
        V = self.link_voltage() if link is None else x[link.iv]  # the modulator's link voltage
        if not V > 0.0:  # a collapsed link applies nothing (pwm_link); the duties then use V_dc
            V = self.link_voltage()
        lk = None if link is None else [link, chop, fault, None]  # the link's running (chop, fault, t_fault)
        half = 0.5 * V
        t1 = t0 + dt
        end = t1 - eps
        start = t0 - eps
        s, dead, dead_until, dead_v = self.s, self.dead, self.dead_until, self.dead_v
        k = math.floor(start / T_h)
        evs, ei = [], 0
        tp = t0
        en = [0.0] * 5  # E_term, E_cond, E_sw, E_cu_s, E_fe [J]
        k_edge = self.k_edge
        cur = None  # the phase currents at tp, once computed
        legs = None  # the interval's legs (signs, drops: _legs), once computed
        sa = sb = 0.0
        while True:
            while ei == len(evs) and k * T_h < end:
                if not self.have or k != self.k:
                    self.d = list(duties(v_alpha, v_beta, V))
                    self.k, self.have = k, True
                evs, ei = half_edges(k, T_h, self.d), 0
                k += 1
            te = evs[ei][0] if ei < len(evs) else _INF
            tn, xd = _INF, -1
            for j in range(3):
                if dead[j] and dead_until[j] < tn:
                    tn, xd = dead_until[j], j
            if tn > te:  # dead-interval ends first at a tie
                tn, xd = te, -1
            if not tn < end:
                break
            if xd < 0:  # an edge that changes nothing (a leg held over a half-period boundary): no interval
                _, _, j, new = evs[ei]
                if s[j] == new and tn >= start:
                    ei += 1
                    continue
            if tn - tp >= eps:
                if legs is None:
                    legs, cur = self._legs(plant, x, cur)
                x1, ia, ib = self._advance(plant, lk, x, tp, tn - tp, legs, half, T_load, h_int, trace)
                self._account(plant, x, x1, ia, ib, tn - tp, legs, en)
                x = x1
                sa += ia
                sb += ib
                tp, cur, legs = tn, None, None
            if xd >= 0:
                dead[xd] = False
                legs = None
                continue
            e, _, j, new = evs[ei]
            ei += 1
            if k_edge > 0.0 and s[j] >= 0 and new != s[j] and e >= start:  # a switching edge's energy
                if cur is None:
                    cur = phase_currents(*plant.outputs(x)[:2])
                en[2] += k_edge * (V if link is None else x[link.iv]) * abs(cur[j])
            if s[j] < 0 or e < start:  # unknown state, or an edge of the last step: no dead interval
                s[j] = new
                legs = None
                continue
            if new == s[j]:
                continue
            s[j] = new
            legs = None
            if t_dead > 0.0:
                if cur is None:
                    cur = phase_currents(*plant.outputs(x)[:2])
                i = cur[j]
                dead[j] = True
                dead_until[j] = e + t_dead
                dead_v[j] = -half if i > 0.0 else half if i < 0.0 else (half if new else -half)
        if legs is None:
            legs, cur = self._legs(plant, x, cur)
        x1, ia, ib = self._advance(plant, lk, x, tp, t1 - tp, legs, half, T_load, h_int, trace)
        self._account(plant, x, x1, ia, ib, t1 - tp, legs, en)
        x = x1
        sa += ia
        sb += ib
        self.energies = tuple(en)
        if lk is not None:
            self.link_out = tuple(lk[1:])
        return x, sa / dt, sb / dt

    def _legs(self, plant, x, cur):
        """The constant interval's legs, the one rule of either link: ``((sig, dl), cur)`` with each leg's
        sign ``sig[j]`` (+1 the upper device or diode conducts, -1 the lower; a dead leg's diode by the
        sign of its dead voltage) and on-state drop term ``dl[j]`` [V] (``-v_on`` for a positive phase
        current, ``+v_on`` for a negative one, 0 for none or without drops); ``cur`` the phase currents
        [A] at ``x``, computed here when the drops need them and they are not given.  The phase voltage is
        ``sig[j] v_dc / 2 + dl[j]`` (:func:`leg_volts`; on the capacitor link at every RK4 stage's own
        ``v_dc``, :mod:`~satmotor.converter.pwm_link`)."""
        sig = [1.0 if (self.dead_v[j] > 0.0 if self.dead[j] else self.s[j] == 1) else -1.0 for j in range(3)]
        dl = [0.0, 0.0, 0.0]
        if self.v_on > 0.0:
            if cur is None:
                cur = phase_currents(*plant.outputs(x)[:2])
            dl = [-self.v_on if c > 0.0 else self.v_on if c < 0.0 else 0.0 for c in cur]
        return (sig, dl), cur

    @staticmethod
    def _account(plant, x0, x1, ia, ib, L, legs, en):
        """Add one interval's energies to ``en`` = [E_term, E_cond, E_sw, E_cu_s, E_fe] [J]: its stator
        charge ``Q = (int v_s dt - delta psi_s) / R_s`` [A s] (the stator equation ``v_s = R_s i_s + d
        psi_s/dt`` with the terminal current, R_s at the interval's start), ``E_term = 3/2 v_mean . Q``
        (exact on the ideal link, whose voltage is constant over the interval) and ``E_cond = -3/2 delta .
        Q`` (the drops ``delta``, constant over it); with core loss the stator copper and core losses by
        the trapezoid over the interval at its voltage (the core branch's current follows the switched
        voltage at once: their means, not their values at the step's end)."""
        Rs = plant.stator_resistance(x0)
        qa = (ia - (x1[0] - x0[0])) / Rs
        qb = (ib - (x1[1] - x0[1])) / Rs
        en[0] += 1.5 * (ia * qa + ib * qb) / L
        dl = legs[1]
        if dl[0] != 0.0 or dl[1] != 0.0 or dl[2] != 0.0:
            da, db = alpha_beta(dl[0], dl[1], dl[2])
            en[1] -= 1.5 * (da * qa + db * qb)
        if not plant.R_fe > 0.0:
            return
        va, vb = ia / L, ib / L
        o0, o1 = plant.outputs(x0, va, vb), plant.outputs(x1, va, vb)
        Rs1 = plant.stator_resistance(x1)
        en[3] += 0.75 * L * (Rs * (o0.i_s_alpha * o0.i_s_alpha + o0.i_s_beta * o0.i_s_beta)
                             + Rs1 * (o1.i_s_alpha * o1.i_s_alpha + o1.i_s_beta * o1.i_s_beta))
        en[4] += 0.5 * L * (o0.P_fe + o1.P_fe)

    @staticmethod
    def _advance(plant, lk, x, t, L, legs, half, T_load, h_int, trace):
        """One constant interval of ``L`` [s] from ``t`` with the legs ``legs`` (:meth:`_legs`): ``(x,
        integral of v_alpha, of v_beta)`` [V s], on the ideal link (``lk`` None; ``half`` [V] half its
        voltage) or integrated with the capacitor link (:mod:`pwm_link`; the trace row at the link's voltage
        at ``t``)."""
        n = max(1, math.ceil(L / h_int - 1e-9))
        if lk is None:
            volts = leg_volts(legs, half)
            if trace is not None:
                trace.append((t, L, *volts))
            return plant.step(t, x, volts[0], volts[1], T_load, L, n), volts[0] * L, volts[1] * L
        if trace is not None:
            trace.append((t, L, *leg_volts(legs, 0.5 * x[lk[0].iv])))
        return pwm_link.interval(lk, x, t, L, *legs, T_load, n)

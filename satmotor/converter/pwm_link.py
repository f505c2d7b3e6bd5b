"""The pwm inverter on the capacitor DC link (``inverter = pwm`` with ``dc_link = capacitor``).

Formulation (the switched stage draws its current from the link, whose voltage moves within a step):

* Between two switching instants (one constant interval of :class:`~satmotor.converter.inverter.PwmInverter`)
  each leg ``j`` is fixed: its sign ``sigma_j`` (+1 upper device or upper diode, -1 lower) and its
  on-state drop term ``delta_j`` (``-v_on`` for a positive phase current, ``+v_on`` for a negative
  one, 0 without drops; the sign of the current at the interval's start, as on the ideal link: the
  inverter's one rule, :meth:`~satmotor.converter.inverter.PwmInverter._legs`).  The
  phase voltage is ``v_j = sigma_j v_dc / 2 + delta_j`` with the link voltage ``v_dc`` **a state**:
  the motor, the thermal states and the link ``(v_dc, E_regen, E_chop)`` integrate together over the
  interval by RK4 (``max(1, ceil(L / h_int - 1e-9))`` sub-steps), every stage evaluating the voltages at
  its own ``v_dc``.  The chopper switches and the fault latches at the sub-step ends
  (:class:`~satmotor.converter.dc_link.DCLink`'s rules).
* The link's current: ``i_dc = p_dc / v_dc`` with ``p_dc = 3/2 g . i_s``, ``g`` the alpha/beta vector of
  the legs' ``sigma_j v_dc / 2`` (the current the upper devices carry; the floating star point makes
  the phase currents sum to zero).  ``p_dc - 3/2 v_s . i_s = -3/2 delta . i_s`` is the devices'
  conduction loss.  ``E_regen`` integrates ``max(0, -p_dc)``: the instantaneous power back into the
  link, which with switching includes the reactive energy that flows back within a carrier period.
* The modulator normalizes its duty cycles with the link voltage sampled at the start of the
  communication step that first reaches a half period (a controller's once-per-step measurement);
  the dead-interval diode is chosen as on the ideal link (the sign of the phase current; its voltage
  follows ``v_dc``).
* The step-average voltage (outputs ``v_avg_alpha/beta``) is the RK4 quadrature of the applied voltage
  over the intervals: two integrator entries carried through the interval's RK4 and dropped after.
* ``v_dc <= 0``: no voltage is applied and no current drawn (as :meth:`DCLink.applied`).

The C port is ``fmu/native/core/sm_pwm_link.c`` (the same floats).
"""

from __future__ import annotations

from satmotor.machine.integrate import rk4
from satmotor.machine.phases import alpha_beta as _alpha_beta


def derivatives(t, y, link, sig, dl, T_load, chop):
    """``dy/dt`` of the link's state (motor, thermal, link) followed by the two voltage integrals, for
    the legs' signs ``sig`` and drop terms ``dl`` [V] held (module docstring)."""
    iv = link.iv
    x = y[:iv + 3]
    v_dc = x[iv]
    if v_dc > 0.0:
        half = 0.5 * v_dc
        g = (sig[0] * half, sig[1] * half, sig[2] * half)
        ga, gb = _alpha_beta(*g)
        va, vb = _alpha_beta(g[0] + dl[0], g[1] + dl[1], g[2] + dl[2])
    else:
        ga = gb = va = vb = 0.0
    plant = link.plant
    o = plant.outputs(x[:iv], va, vb)
    d = plant.derivatives(t, x[:iv], va, vb, T_load)
    p_dc = 1.5 * (ga * o.i_s_alpha + gb * o.i_s_beta)
    return (*d, *link.rates(t, v_dc, p_dc, chop), va, vb)


def step(link, t, x, sig, dl, T_load, h, n_sub, chop, fault):
    """Advance the link's state ``x`` over one constant interval of ``h`` [s] in ``n_sub`` RK4 sub-steps
    (times ``t + j h / n_sub``).  Returns ``(x, chop, fault, t_fault, int_va, int_vb)``: ``t_fault`` as
    :meth:`DCLink.step`, ``int_va``, ``int_vb`` [V s] the integrals of the applied voltage."""
    dt = h / n_sub
    t_fault = None
    iv = link.iv
    y = (*x, 0.0, 0.0)
    for j in range(n_sub):
        tj = t + j * dt
        y = rk4(derivatives, tj, y, dt, 1, (link, sig, dl, T_load, chop))
        chop, fault, t_fault = link.substep_end(y[iv], tj + dt, chop, fault, t_fault)
    return y[:iv + 3], chop, fault, t_fault, y[iv + 3], y[iv + 4]


def interval(lk, x, t, L, sig, dl, T_load, n_sub):
    """One constant interval of ``L`` [s] of :meth:`PwmInverter.step` on the capacitor link from ``t`` in
    ``n_sub`` RK4 sub-steps, the legs' signs ``sig`` and drop terms ``dl`` [V] held (the inverter's rule,
    :meth:`~satmotor.converter.inverter.PwmInverter._legs`); ``lk`` = ``[link, chop, fault, t_fault]``,
    updated.  Returns ``(x, int_v_alpha, int_v_beta)``."""
    x, lk[1], fault, t_fault, ia, ib = step(lk[0], t, x, sig, dl, T_load, L, n_sub, lk[1], lk[2])
    if t_fault is not None and lk[3] is None:
        lk[3] = t_fault
    lk[2] = fault
    return x, ia, ib

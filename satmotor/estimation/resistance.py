"""On-line resistance tracking of the closed-loop observer (controller options ``rs_adaptation``,
``rr_tracking``; C: ``fmu/native/core/sm_flux_observer.c``, the same floats).

Stator resistance.  Over one sample both models of :mod:`satmotor.estimation.flux_observer` start from the
same estimate; the voltage model integrates ``v_s - R_s_hat i_s``, so an R_s error adds
``Ts (R_s - R_s_hat) i_s`` to its stator flux and, through the algebra (``dpsi_r/dpsi_s`` about
``k + l_r/(k L)``, positive), about as much to its rotor flux: the residual ``d = psi_v - psi_i``
holds ``Ts c h (R_s - R_s_hat) i_s`` with ``c > 0`` and ``h`` the closed loop's own factor
(``e' = -b e - G c dR i_s`` in steady state gives ``h = (2b - a + j(w_s + w_r))/(b + j w_s)``: 1 at
standstill, 2 at speed with ``b = a``; near real where the flux-axis current dominates).  Along the
flux estimate the speed error (``j n_p (omega_m - omega_hat) psi_hat``, across the flux) and, in steady
state, the rotor-resistance error (the rotor current is across the flux) do not show, so::

    eps_R = Re(d conj(psi_hat)) / (Ts Re(i_s conj(psi_hat)))   [Ohm],   R_s_hat <- R_s_hat + Ts RS_RATE eps_R

(``i_s`` the interval's mean, ``psi_hat`` the estimate at its start): an integral law of rate about
``c h RS_RATE`` [1/s].  Frozen (the estimate held): while the drive is not running the law (the
pre-magnetization: the flux builds, the current model's transient dominates), while a voltage or
current limit was active at the previous sample (the applied voltage may not be what the machine got;
the currents are not the law's), below ``PSI_ADAPT_MIN`` of estimated flux or ``I_ADAPT_MIN`` of
flux-axis current (low excitation: the regressor ``Re(i_s conj psi)`` too small for the noise) and, with
the speed estimated, without load (``|i_sq| < LOAD_MIN i_sd``: at no load and at standstill without load
the flux-axis residual and the speed estimate form one mode that the adaptation destabilized: on the warm
default motor R_s_hat fell from +0 % to -45 % at 100 rad/s without load); bounded to ``[RS_MIN, RS_MAX]``
times the given R_s.  Not identifiable against a magnetizing-curve error: an L_m error shows along the
flux like an R_s error (the current model's magnetizing current), so with the plant's L_m0 -20 % the
estimate runs to a bound; the adaptation assumes the curve right.

Rotor resistance (temperature).  In steady state R_r is seen only through the slip, and with the speed
estimated the slip and the speed are not separable (``R_r/omega_slip`` is all the fundamental waves
give); the temperature is: ``R_s_hat = R_s (1 + alpha_s dT)`` gives dT, and with the rotor at the
stator's temperature ``R_r_hat = R_r (1 + alpha_r dT) = R_r (1 + (alpha_r/alpha_s)(R_s_hat/R_s - 1))``
(copper winding, aluminium cage: the plant's coefficients, :mod:`satmotor.machine.thermal`).  It moves
(and freezes) with R_s_hat; it does not see a rotor resistance that is off for another reason than
the temperature.  The drive's law uses both estimates (its model's R_s, R_r); the pre-magnetization,
the delay compensation and the field weakening keep the given values.
"""

from __future__ import annotations

from satmotor.machine.thermal import ALPHA_ALUMINIUM, ALPHA_COPPER

RS_RATE = 20.0  # [1/s] integral rate of the stator-resistance adaptation
I_ADAPT_MIN = 0.5  # [A] flux-axis stator current below which R_s_hat is held (low excitation)
LOAD_MIN = 0.5  # [1] with the speed estimated, R_s_hat is held while |i_sq| < LOAD_MIN i_sd (no load)
RS_MIN, RS_MAX = 0.5, 2.0  # [1] the bounds of R_s_hat, relative to the given R_s
ALPHA_RATIO = ALPHA_ALUMINIUM / ALPHA_COPPER  # [1] alpha_r / alpha_s


def rotor_resistance(R_s_hat, R_s, R_r):
    """R_r_hat [Ohm] at the temperature R_s_hat [Ohm] implies, the given R_s, R_r [Ohm] at T_ref."""
    return R_r * (1.0 + ALPHA_RATIO * (R_s_hat / R_s - 1.0))


def adapt_stator_resistance(R_s_hat, R_s, Ts, da, db, pa, pb, ia, ib, n2, loaded_only=False):
    """One sample of the R_s adaptation: the new R_s_hat [Ohm] from the residual ``(da, db)`` [Wb], the
    estimate ``(pa, pb)`` [Wb] (``n2`` its squared magnitude [Wb^2], >= PSI_ADAPT_MIN^2: the caller's
    test), the interval's mean current ``(ia, ib)`` [A]; R_s_hat unchanged at low excitation and, with
    ``loaded_only`` (the speed estimated), without load."""
    q = ia * pa + ib * pb  # Re(i_s conj psi) = |psi| i_sd [Wb A]
    if q <= 0.0 or q * q < I_ADAPT_MIN * I_ADAPT_MIN * n2:
        return R_s_hat
    if loaded_only and abs(ib * pa - ia * pb) < LOAD_MIN * q:  # Im(i_s conj psi) = |psi| i_sq
        return R_s_hat
    r = R_s_hat + Ts * RS_RATE * ((da * pa + db * pb) / (Ts * q))
    return min(max(r, RS_MIN * R_s), RS_MAX * R_s)


__all__ = ["ALPHA_RATIO", "I_ADAPT_MIN", "RS_MAX", "RS_MIN", "RS_RATE", "adapt_stator_resistance",
           "rotor_resistance"]

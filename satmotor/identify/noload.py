"""No-load test -> magnetizing points (peak i_mu [A], peak psi_m [Wb]), numpy only.

The no-load test: the motor runs uncoupled at (about) rated frequency while the supply voltage is
varied; per voltage level one records the line-to-line voltage ``V_ll_rms`` [V], the line current
``I_rms`` [A], the frequency ``f`` [Hz] and, optionally, the input power ``P_in`` [W] (star
connection, balanced sinusoidal supply).  Each row becomes one point of the magnetizing curve in
the project's conventions (amplitude-invariant Clarke transform: a space vector's magnitude is the
phase peak; :mod:`satmotor.machine.plant`), through these steps and corrections:

1. Peaks: phase voltage ``V = sqrt(2) V_ll_rms / sqrt(3)``, current ``I = sqrt(2) I_rms``,
   ``omega_e = 2 pi f``.
2. Current angle.  With ``P_in``: the power factor ``cos(phi) = P_in / (sqrt(3) V_ll_rms I_rms)``
   (``= P_in / (3/2 V I)``), the current phasor lags the voltage by phi.  ``P_in`` must lie in
   ``[0, sqrt(3) V_ll_rms I_rms]``.
3. Stator impedance: the main-flux EMF ``E_m = V - (R_s + j omega_e l_s) I`` (phasors), so the
   stator copper loss ``R_s I^2`` and the leakage drop are removed; ``psi_m = |E_m| / omega_e``.
4. Magnetizing current.  At no load the slip is about 0 and ``i_mu = i_s + k i_r`` is about
   ``i_s``, but not quite: the rotor carries the current that makes the friction torque (and, in a
   real machine, the iron-loss current flows in parallel with the main field).  Both are in phase
   with ``E_m`` (the rotor branch is ``R_r / s`` at a slip ``s`` near 0, the iron loss a
   resistance), while ``i_mu`` lags ``E_m = j omega_e psi_m`` by exactly 90 deg
   (``psi_m = m(|i_mu|) i_mu`` is collinear with ``i_mu``).  So with ``P_in`` we take
   ``i_mu`` = **the component of I in quadrature with E_m** (lagging it by 90 deg); the in-phase
   (loss) component is discarded.  On the plant of this package (no iron loss) the in-phase part
   is the rotor current of the friction torque ``B omega_m``, which is not small at low voltage:
   at 20 % of rated voltage the default motor's friction needs a rotor current of about the size
   of i_mu itself, so the quadrature component matters there.
   *Rotor leakage*: the rotor branch is ``R_r / s + j omega_e l_r``, not purely resistive, so its
   current also has a small lagging part ``I_p^2 omega_e l_r / |E_m|`` (``I_p`` the in-phase
   component of I, ``R_r / s ~ |E_m| / I_p``), which the quadrature component would count as
   magnetizing; it is subtracted, with ``l_r = l_s`` (the usual split of the leakage when only the
   total is known) unless ``l_r`` is given.  On the default motor at 20 % voltage this term is
   2.5 % of i_mu, at 40 % 0.3 %.  Were the in-phase current iron-loss current instead (no
   reactance in series), the term would be wrongly subtracted, but it is then negligible: it is
   ``I_p^2 omega_e l_r / |E_m|``, about 1e-4 of i_mu for a loss current of 5 % of the line current.
5. Without ``P_in`` the current is **assumed purely magnetizing**: ``i_mu = I``, lagging ``E_m``
   by 90 deg.  Then ``V = R_s I + j omega_e (l_s I + psi_m)`` (i_mu on the real axis) gives
   ``psi_m = sqrt(V^2 - (R_s I)^2) / omega_e - l_s I``.  This overestimates i_mu by the loss
   current: small near rated voltage, large at low voltage where the friction (and iron-loss)
   current is a large part of the line current.  Record P_in when you can.

6. Measurement tolerance.  ``P_in`` below the stator copper loss ``3 R_s I_rms^2`` is impossible
   for the model, but real (and exactly lossless synthetic) data get there by rounding and noise.
   Within ``copper_tol`` (relative, default 5 %) below it, the row is taken as **no loss**
   (``P_in = 3 R_s I_rms^2``) and a warning names the row; further below, the row is refused.
7. Iron loss.  ``P_in - 3 R_s I_rms^2`` (the no-load loss ``P_loss``) is core loss plus friction
   and windage: :func:`separate_losses` fits ``P_loss = 3/2 |E_m|^2 / R_fe + P_fw`` over the rows
   (core loss in a resistance R_fe across the main field; friction constant at the near-synchronous
   no-load speed: the classical separation).  Given ``R_fe``, the core-loss current ``|E_m| / R_fe``
   is removed from the in-phase current before the rotor-leakage correction of step 4.

Errors are :class:`satmotor.errors.ParameterError` naming the quantity and, in ``field``, the row
index (``V_ll_rms[3]``); the CLI (``orchestration.tools.fit_curve``) maps the index to the file line.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from satmotor.errors import ParameterError, require_number

SQRT2, SQRT3 = math.sqrt(2.0), math.sqrt(3.0)
COPPER_TOL = 0.05  # [1] P_in this far below the stator copper loss is taken as no loss (step 6)


class MagnetizingPoints(NamedTuple):
    """Magnetizing points of a no-load test, one per row, in the row order."""

    i_mu: np.ndarray  # [A] peak magnetizing current (space-vector magnitude)
    psi_m: np.ndarray  # [Wb] peak main flux linkage
    I_s: np.ndarray  # [A] peak line (stator) current
    cos_phi: np.ndarray | None  # [1] power factor (None: no P_in, current assumed purely magnetizing)
    E_m: np.ndarray | None = None  # [V] peak main-flux EMF |E_m| (None without P_in)
    P_loss: np.ndarray | None = None  # [W] P_in - 3 R_s I_rms^2 (>= 0; None without P_in)
    warnings: tuple = ()  # ((row index, message), ...): rows taken as lossless (step 6)
    E_s: np.ndarray | None = None  # [V] peak stator emf |V - R_s I| (the plant's core-loss voltage; None
    # without P_in)
    cov: np.ndarray | None = None  # (n, 2, 2) covariance of (i_mu [A], psi_m [Wb]) of each point, from the
    # readings' uncertainty (satmotor.identify.uncertainty.noload_points; None: not computed)


class LossSeparation(NamedTuple):
    """Result of :func:`separate_losses`."""

    R_fe: float  # [Ohm] core-loss resistance across the main field (0: no core loss found)
    P_fw: float  # [W] friction and windage loss (constant over the rows)
    rms: float  # [W] RMS residual of the fit of P_loss
    R_fe_plant: float | None = None  # [Ohm] the plant's R_fe (plant_core_loss_resistance), once known


def _row_array(name, values, n=None):
    a = np.asarray(values, dtype=float).ravel()
    if n is not None and a.size != n:
        raise ParameterError(name, a.size, f"has {a.size} rows, V_ll_rms has {n}")
    bad = np.nonzero(~np.isfinite(a))[0]
    if bad.size:
        k = int(bad[0])
        raise ParameterError(f"{name}[{k}]", float(a[k]), "must be a finite number")
    return a


def magnetizing_points(V_ll_rms, I_rms, f, R_s, l_s, P_in=None, l_r=None, copper_tol=COPPER_TOL, R_fe=0.0):
    """Convert no-load test rows to magnetizing points (see the module docstring).

    Parameters
    ----------
    V_ll_rms, I_rms, f : array_like
        Line-to-line voltage [V rms], line current [A rms], supply frequency [Hz], all > 0.
    R_s, l_s : float
        Stator resistance [Ohm] and stator leakage inductance [H], finite and >= 0.
    P_in : array_like or None
        Input power [W], 0 <= P_in <= sqrt(3) V_ll_rms I_rms; None: not measured.
    l_r : float or None
        Rotor leakage inductance [H] for the rotor-leakage correction (used with P_in only);
        None: ``l_r = l_s``.
    copper_tol : float
        Relative tolerance [1], >= 0, of P_in below the stator copper loss (step 6).
    R_fe : float
        Core-loss resistance [Ohm] (0: none), its current left out of the rotor-leakage correction.

    Returns
    -------
    MagnetizingPoints
    """
    R_s = require_number("R_s", R_s, 0.0, inclusive=True)
    l_s = require_number("l_s", l_s, 0.0, inclusive=True)
    l_r = l_s if l_r is None else require_number("l_r", l_r, 0.0, inclusive=True)
    copper_tol = require_number("copper_tol", copper_tol, 0.0, inclusive=True)
    R_fe = require_number("R_fe", R_fe, 0.0, inclusive=True)
    warnings = []
    V_ll = _row_array("V_ll_rms", V_ll_rms)
    n = V_ll.size
    I_r = _row_array("I_rms", I_rms, n)
    fr = _row_array("f", f, n)
    for name, a in (("V_ll_rms", V_ll), ("I_rms", I_r), ("f", fr)):
        bad = np.nonzero(a <= 0.0)[0]
        if bad.size:
            k = int(bad[0])
            raise ParameterError(f"{name}[{k}]", float(a[k]), "must be > 0")
    V = SQRT2 * V_ll / SQRT3
    I = SQRT2 * I_r
    w = 2.0 * math.pi * fr
    if P_in is None:
        rad = V * V - (R_s * I) ** 2
        bad = np.nonzero(rad <= 0.0)[0]
        if bad.size:
            k = int(bad[0])
            raise ParameterError(f"V_ll_rms[{k}]", float(V_ll[k]),
                                 f"is below the stator resistance drop R_s I = {R_s * I[k]:.6g} V (peak)")
        psi = np.sqrt(rad) / w - l_s * I
        i_mu = I.copy()
        cos_phi = Eabs = P_loss = None
    else:
        P = _row_array("P_in", P_in, n).copy()
        S = SQRT3 * V_ll * I_r
        for k in range(n):
            if P[k] < 0.0:
                raise ParameterError(f"P_in[{k}]", float(P[k]), "must be >= 0 (a motor takes power)")
            if P[k] > S[k]:
                raise ParameterError(f"P_in[{k}]", float(P[k]), f"is greater than the apparent power "
                                     f"sqrt(3) V_ll_rms I_rms = {S[k]:.6g} VA")
            copper = 1.5 * R_s * I[k] ** 2  # = 3 R_s I_rms^2
            if P[k] < copper * (1.0 - copper_tol):
                raise ParameterError(f"P_in[{k}]", float(P[k]), f"is less than the stator copper loss "
                                     f"3 R_s I_rms^2 = {copper:.6g} W by more than the tolerance "
                                     f"{copper_tol:.3g} (relative): check R_s and P_in")
            if P[k] < copper:
                warnings.append((k, f"P_in = {float(P[k])!r} W is below the stator copper loss "
                                    f"3 R_s I_rms^2 = {copper:.6g} W, within the tolerance {copper_tol:.3g}: "
                                    "taken as no loss"))
                P[k] = min(copper, S[k])
        cos_phi = P / S
        sin_phi = np.sqrt(np.clip(1.0 - cos_phi * cos_phi, 0.0, None))
        Ic = I * (cos_phi - 1j * sin_phi)  # the voltage phasor on the real axis, current lagging by phi
        E = V - (R_s + 1j * w * l_s) * Ic
        Eabs = np.abs(E)
        psi = Eabs / w
        # component of I lagging E by 90 deg: Re(I conj(-j E / |E|)) = Re(j I conj(E)) / |E|
        with np.errstate(divide="ignore", invalid="ignore"):
            i_quad = np.real(1j * Ic * np.conj(E)) / Eabs
            i_p = np.real(Ic * np.conj(E)) / Eabs  # in phase with E_m: rotor (friction) / iron-loss current
        i_rot = np.clip(i_p - (Eabs / R_fe if R_fe > 0.0 else 0.0), 0.0, None)  # the rotor's in-phase part
        i_mu = i_quad - i_rot * i_rot * w * l_r / Eabs  # minus the lagging part of the rotor-branch current
        P_loss = np.clip(P - 1.5 * R_s * I * I, 0.0, None)
    for k in range(n):
        if not (psi[k] > 0.0 and i_mu[k] > 0.0):
            raise ParameterError(f"row[{k}]", (float(V_ll[k]), float(I_r[k])),
                                 f"gives no positive magnetizing point (psi_m = {psi[k]:.6g} Wb, "
                                 f"i_mu = {i_mu[k]:.6g} A): check R_s, l_s and the row's values")
    E_s = None if P_in is None else np.abs(V - R_s * Ic)
    return MagnetizingPoints(i_mu, psi, I, cos_phi, Eabs, P_loss, tuple(warnings), E_s)


CORE_LOSS_FLOOR = 1e-6  # [1] a core loss below this share of the input power (top row) is none


def separate_losses(E_m, P_loss, P_in, cov=None):
    """Core loss and friction from the no-load loss: least squares of ``P_loss = 3/2 E_m^2 / R_fe +
    P_fw`` over the rows (``E_m`` [V] peak EMF, ``P_loss`` [W], as :class:`MagnetizingPoints` gives
    them; ``P_in`` [W] the input power); :class:`LossSeparation`.  No loss growing with the voltage
    (a slope <= 0, or a core loss at the highest EMF below ``CORE_LOSS_FLOOR`` of that row's input
    power) gives ``R_fe = 0`` (none) and ``P_fw`` the mean loss.  At least 2 rows.

    ``cov`` [(n, 2, 2)]: the covariance of ``(E_m^2, P_loss)`` of each row
    (:mod:`satmotor.identify.uncertainty`); None: all rows weighted alike, no error in ``E_m^2``.
    With it, both variables carry errors, and each row is weighted by its effective variance
    ``var(P_loss) + a^2 var(E_m^2) - 2 a cov(E_m^2, P_loss)`` along the line of slope ``a``
    (errors in variables, the line's maximum likelihood for Gaussian errors): the weighted least
    squares is repeated with the weights of the last slope until the slope stops changing."""
    E2 = np.asarray(E_m, dtype=float) ** 2
    y = np.asarray(P_loss, dtype=float)
    if E2.size < 2 or y.size != E2.size:
        raise ParameterError("P_in", y.size, "needs at least 2 rows to separate core and friction loss")
    A = np.column_stack([E2, np.ones_like(E2)])
    (slope, P_fw), *_ = np.linalg.lstsq(A, y, rcond=None)
    if cov is not None:
        c = np.asarray(cov, dtype=float)
        for _ in range(200):
            var = c[:, 1, 1] + slope * slope * c[:, 0, 0] - 2.0 * slope * c[:, 0, 1]
            w = 1.0 / np.sqrt(np.maximum(var, 1e-300))
            (s2, P_fw), *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
            done = abs(s2 - slope) <= 1e-13 * abs(slope)
            slope = s2
            if done:
                break
    top = int(np.argmax(E2))
    if not slope * E2[top] > CORE_LOSS_FLOOR * float(np.asarray(P_in, dtype=float)[top]):
        P_fw = float(np.mean(y))
        return LossSeparation(0.0, P_fw, float(np.sqrt(np.mean((y - P_fw) ** 2))))
    rms = float(np.sqrt(np.mean((A @ np.array([slope, P_fw]) - y) ** 2)))
    return LossSeparation(1.5 / float(slope), float(P_fw), rms)


def plant_core_loss_resistance(R_fe, E_m, E_s):
    """The plant's R_fe [Ohm] for a core-loss resistance ``R_fe`` [Ohm] found across the main-flux EMF
    ``E_m`` (step 7): the plant (:mod:`satmotor.machine.thermal`) puts it across the stator emf
    ``e_s = v_s - R_s i_s`` (``E_s`` [V] peak, :class:`MagnetizingPoints`), ahead of the stator leakage.
    Least squares over the rows of ``3/2 E_s^2 / R = 3/2 E_m^2 / R_fe`` (the plant's core loss at the
    test points against the separated one): ``R = R_fe sum(E_s^4) / sum(E_s^2 E_m^2)``; with l_s = 0
    (``E_s = E_m``) exactly R_fe.  0 stays 0 (no core loss)."""
    if R_fe == 0.0:
        return 0.0
    es2 = np.asarray(E_s, dtype=float) ** 2
    em2 = np.asarray(E_m, dtype=float) ** 2
    return float(R_fe * np.sum(es2 * es2) / np.sum(es2 * em2))

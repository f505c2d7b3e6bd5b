"""Reference shaping: smooth set-points with exact first and second derivatives.

A raw set-point ``u(t)`` (steps, ramps: any piecewise-constant or piecewise-linear
signal the caller samples) is passed through the critically damped third-order
filter ``R(s) / U(s) = w_n^3 / (s + w_n)^3``, written with the states
``z = (r, r', r'')``::

    r''' = w_n^3 (u - r) - 3 w_n^2 r' - 3 w_n r''

i.e. ``z' = A z + b u`` with the companion matrix ``A = [[0, 1, 0], [0, 0, 1],
[-w^3, -3 w^2, -3 w]]`` and ``b = (0, 0, w^3)``.  The derivatives ``r'``, ``r''``
are states, hence exact (no numerical differentiation); ``r`` is C^2 in time.

Exact zero-order-hold discretization.  The characteristic polynomial of ``A`` is
``(s + w)^3``, so ``N = A + w I`` is nilpotent (``N^3 = 0``, Cayley-Hamilton) and

    Phi(h) = exp(A h) = exp(-w h) (I + h N + h^2/2 N^2)          (closed form)

The equilibrium for a held input is ``(u, 0, 0)`` (DC gain 1), so the ZOH input
vector is ``Gamma(h) = int_0^h exp(A s) b ds = (I - Phi) e_1`` and one step is
``z_next = Phi z + Gamma u = (u, 0, 0) + Phi (z - (u, 0, 0))``; the latter form is
used (it is exact and keeps full relative accuracy near the set-point).  ``Phi``
is computed once per step size ``h`` and cached; the per-call path is plain floats.

``u``, ``r`` are the filter's own names: in the drive (:mod:`satmotor.control.drive`) ``u`` is a raw
set-point, ``omega_ref`` or ``psi_ref``, and ``(r, r', r'')`` the shaped reference the law tracks,
``omega_ref_shaped`` or ``psi_ref_shaped`` (with its derivatives).
"""

from __future__ import annotations

import math

from satmotor.errors import ParameterError, require_number

_CACHE_SIZE = 8
# Layout of a shaper's state and value tuple (r, r', r'').
REF_VALUE, REF_RATE, REF_ACCEL = range(3)


def transition_matrix(bandwidth, h):
    """``Phi = exp(A h)`` of the shaper with ``w_n = bandwidth`` [rad/s] over ``h`` [s].

    Returns a 3-tuple of row 3-tuples (closed form, see the module docstring).
    """
    w = require_number("bandwidth", bandwidth, 0)
    h = require_number("h", h, 0)
    w2, w3 = w * w, w * w * w
    N = ((w, 1.0, 0.0), (0.0, w, 1.0), (-w3, -3.0 * w2, -2.0 * w))
    N2 = ((w2, 2.0 * w, 1.0), (-w3, -2.0 * w2, -w), (w3 * w, 2.0 * w3, w2))
    e = math.exp(-w * h)
    hh = 0.5 * h * h
    return tuple(
        tuple(e * ((1.0 if i == j else 0.0) + h * N[i][j] + hh * N2[i][j]) for j in range(3))
        for i in range(3)
    )


def input_vector(bandwidth, h):
    """ZOH input vector ``Gamma = int_0^h exp(A s) b ds = (I - Phi) e_1`` (3-tuple)."""
    P = transition_matrix(bandwidth, h)
    # 1 - Phi_00 = 1 - exp(-x)(1 + x + x^2/2), summed without cancellation for small x
    x = bandwidth * h
    if x < 0.5:
        term, s, n = x * x * x / 6.0, 0.0, 3
        while term > 1e-17 * s:
            s += term
            n += 1
            term *= x / n
        g0 = math.exp(-x) * s  # exp(-x) * sum_{n>=3} x^n / n!
    else:
        g0 = 1.0 - P[0][0]
    return (g0, -P[1][0], -P[2][0])


def _cdf3(x):
    """Unit-step response of w^3/(s + w)^3 at ``x = w t``: 1 - exp(-x)(1 + x + x^2/2)."""
    return 1.0 - math.exp(-x) * (1.0 + x + 0.5 * x * x)


def _solve_cdf3(level):
    lo, hi = 0.0, 50.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _cdf3(mid) < level:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


#: ``w_n t_r`` for the 10-90 % rise time of the critically damped third-order step response.
RISE_TIME_PRODUCT = _solve_cdf3(0.9) - _solve_cdf3(0.1)


def design_bandwidth_from_rise_time(t_r):
    """Bandwidth ``w_n`` [rad/s] giving the 10-90 % step rise time ``t_r`` [s].

    ``w_n = RISE_TIME_PRODUCT / t_r`` with ``RISE_TIME_PRODUCT`` = 4.2202 (from
    ``1 - exp(-x)(1 + x + x^2/2)`` = 0.1 and 0.9).
    """
    return RISE_TIME_PRODUCT / require_number("t_r", t_r, 0)


class ReferenceShaper:
    """Critically damped third-order reference filter ``w_n^3 / (s + w_n)^3``, exact ZOH steps.

    Parameters
    ----------
    bandwidth : float
        ``w_n`` [rad/s], finite and > 0.  The 10-90 % step rise time is 4.22 / w_n;
        the step response never overshoots.
    initial : float
        Initial value of ``r`` (at rest: ``r' = r'' = 0``), in the unit of the signal.
    """

    __slots__ = ("bandwidth", "_r", "_r1", "_r2", "_h", "_phi", "_cache")

    def __init__(self, bandwidth, initial=0.0):
        self.bandwidth = require_number("bandwidth", bandwidth, 0)
        self._h = None
        self._phi = None
        self._cache = {}
        self.reset(initial)

    def _coefficients(self, h):
        phi = self._cache.get(h)
        if phi is None:
            P = transition_matrix(self.bandwidth, h)  # checks h
            phi = P[0] + P[1] + P[2]  # flat 9-tuple, row major
            if len(self._cache) >= _CACHE_SIZE:
                self._cache.clear()
            self._cache[h] = phi
        self._h = h
        self._phi = phi
        return phi

    def step(self, u, h):
        """Advance by ``h`` [s] with the raw set-point ``u`` held; return ``(r, r', r'')``."""
        phi = self._phi if h == self._h else self._coefficients(h)
        if not math.isfinite(u):  # per-sample fast path; require_number raises
            require_number("u", u)
        e0 = self._r - u
        r1, r2 = self._r1, self._r2
        p00, p01, p02, p10, p11, p12, p20, p21, p22 = phi
        self._r = u + (p00 * e0 + p01 * r1 + p02 * r2)
        self._r1 = p10 * e0 + p11 * r1 + p12 * r2
        self._r2 = p20 * e0 + p21 * r1 + p22 * r2
        return self._r, self._r1, self._r2

    def reset(self, value=0.0):
        """Put the filter at rest at ``value``: ``(r, r', r'') = (value, 0, 0)``."""
        self._r, self._r1, self._r2 = require_number("value", value), 0.0, 0.0

    @property
    def value(self):
        """Current ``(r, r', r'')`` [unit, unit/s, unit/s^2]."""
        return self._r, self._r1, self._r2

    def get_state(self):
        """The complete dynamic state ``(r, r', r'')`` (the cached ``Phi`` is not state)."""
        return self._r, self._r1, self._r2

    def set_state(self, state):
        """Restore a state returned by :meth:`get_state`."""
        try:
            r, r1, r2 = (float(v) for v in state)
        except (TypeError, ValueError) as exc:
            raise ParameterError("state", state, "must be three numbers (r, r', r'')") from exc
        if not (math.isfinite(r) and math.isfinite(r1) and math.isfinite(r2)):
            raise ParameterError("state", state, "must be finite")
        self._r, self._r1, self._r2 = r, r1, r2

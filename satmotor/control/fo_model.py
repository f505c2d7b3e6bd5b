"""The seed's rotor-flux-oriented control model (section 3), in the corrected compact form.

State ``x = [Phi_rd, i_mu_d, i_mu_q, omega_m]`` ([Wb], [A], [A], [rad/s]) in the
frame rotating with the rotor flux (Phi_rq = 0); inputs ``v = [v_sd, v_sq]`` [V]
and the load torque ``T_load`` [N m]::

    x' = F(x) + G(x) v

Derivation (equivalent to seed eqs 24, 28-40 with the corrections of
``docs/errata.md``; the seed's coefficients a, b3, g0 divide by M_dq and
are singular at i_mu_q = 0, this form is not).  With ``sigma = 1 + k^2 l_s/l_r``,
``M`` the dynamic inductance matrix and ``L = l_s I2 + sigma M``::

    i_s   = (1 + k^2 m / l_r) i_mu - (k / l_r) Phi_rd e_d
    psi_s = (l_s + sigma m) i_mu - (k l_s / l_r) Phi_rd e_d
    Phi_rd' = (R_r / l_r)(k m i_mu_d - Phi_rd)                          (eq 24)
    omega_s = n_p omega_m + R_r k m i_mu_q / (l_r Phi_rd)               (eq 28)
    L i_mu' = v_s - R_s i_s - omega_s J2 psi_s + (k l_s / l_r) Phi_rd' e_d
    J omega_m' = kappa k m Phi_rd i_mu_q / l_r - T_load - B omega_m,  kappa = 3/2 n_p

The flux angle obeys ``rho' = omega_s``.

:func:`vector_fields` is the one implementation of these equations (plain floats, the
per-sample path): :class:`FluxOrientedModel` and the backstepping law both call it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from satmotor.machine.magnetics import inductance_matrix
from satmotor.machine.plant import N_STATES, OMEGA_M, PSI_R_A, PSI_R_B, PSI_S_A, PSI_S_B, THETA_M

PHI_RD, I_MU_D, I_MU_Q, OMEGA = range(4)


class ModelConstants(NamedTuple):
    """Parameter groups of the control model, derived once from a :class:`MotorParams` (SI)."""

    k: float  # [1] turns ratio
    l_s: float  # [H]
    R_s: float  # [Ohm]
    n_p: int  # [1]
    a: float  # R_r / l_r [1/s]
    ak: float  # a k [1/s]
    K: float  # kappa k / (J l_r) [1/(kg m2 H)]: T_e / J = K m Phi_rd i_mu_q
    b: float  # B / J [1/s]
    sigma: float  # 1 + k^2 l_s / l_r [1]
    k_lr: float  # k / l_r [1/H]
    k2_lr: float  # k^2 / l_r [1/H]
    kls_lr: float  # k l_s / l_r [1]

    @classmethod
    def of(cls, p):
        k, lr, ls = p.k, p.l_r, p.l_s
        a = p.R_r / lr
        k_lr = k / lr
        return cls(k, ls, p.R_s, p.n_p, a, a * k, 1.5 * p.n_p * k / (p.J * lr), p.B / p.J,
                   1.0 + k * k * ls / lr, k_lr, k * k_lr, ls * k_lr)


_CONSTANTS = {}  # id(params) -> (params, ModelConstants); MotorParams is frozen


def model_constants(params):
    """The :class:`ModelConstants` of ``params`` (computed once per parameter object)."""
    owner, c = _CONSTANTS.get(id(params), (None, None))
    if owner is params:
        return c
    c = ModelConstants.of(params)
    if len(_CONSTANTS) >= 16:
        _CONSTANTS.clear()
    _CONSTANTS[id(params)] = (params, c)
    return c


def flux_rate(a, k, phi, i_mu_d, m):
    """``Phi_rd' = a (k m i_mu_d - Phi_rd)`` [Wb/s] with ``a = R_r/l_r`` (eq 24; no input enters it)."""
    return a * (k * m * i_mu_d - phi)


def vector_fields(c, phi, imd, imq, w, m, dm, I, theta, phi_ws):
    """Drift F and input matrix of ``x' = F(x) + G(x) v`` at ``x = (phi, imd, imq, w)``: the one
    derivation of the control model (module docstring), used by :class:`FluxOrientedModel` and by
    the backstepping law.

    ``c`` the :class:`ModelConstants`; m [H] and dm [H/A] the static inductance and its derivative
    at ``I = |i_mu|`` [A] (m may be measured); theta = T_load/J [rad/s^2]; phi_ws [Wb] the flux
    used in the slip term of omega_s (``phi`` itself, or the law's guarded ``max(phi, phi_min)``).
    ``G = ((0, 0), (g_dd, g_dq), (g_dq, g_qq), (0, 0))`` with ``[[g_dd, g_dq], [g_dq, g_qq]] = L^-1``.

    Returns the tuple ``(F_phi, F_d, F_q, F_w, g_dd, g_dq, g_qq, omega_s, M_d, M_q, M_dq, i_sd,
    i_sq, psi_sd, psi_sq, T_e/J, det L)`` [Wb/s, A/s, A/s, rad/s^2, 1/H x3, rad/s, H x3, A, A, Wb,
    Wb, rad/s^2, H^2].
    """
    k, ls, R_s, n_p, a, ak, K, b, sg, k_lr, k2_lr, kls_lr = c
    Md, Mq, Mdq = inductance_matrix(m, dm, imd, imq, I)
    l11, l22, l12 = ls + sg * Md, ls + sg * Mq, sg * Mdq
    detL = l11 * l22 - l12 * l12
    a11, a22, a12 = l22 / detL, l11 / detL, -l12 / detL
    cc = 1.0 + k2_lr * m
    ls_sm = ls + sg * m
    isd = cc * imd - k_lr * phi
    psd = ls_sm * imd - kls_lr * phi
    dphi = flux_rate(a, k, phi, imd, m)
    ws = n_p * w + ak * m * imq / phi_ws
    r1 = -R_s * isd + ws * ls_sm * imq + kls_lr * dphi
    r2 = -R_s * cc * imq - ws * psd
    te_J = K * m * phi * imq
    return (dphi, a11 * r1 + a12 * r2, a12 * r1 + a22 * r2, te_J - theta - b * w, a11, a12, a22, ws,
            Md, Mq, Mdq, isd, cc * imq, psd, ls_sm * imq, te_J, detL)


class FluxOrientedModel:
    """The control model ``x' = F(x) + G(x) v`` bound to one parameter set.

    Parameters
    ----------
    params : satmotor.machine.params.MotorParams
    """

    def __init__(self, params):
        self.p = params
        self._c = ModelConstants.of(params)

    def fields(self, x, T_load):
        """Return ``(F, G, aux)`` at state ``x`` (:func:`vector_fields` with m from the curve).

        F is a 4-tuple [Wb/s, A/s, A/s, rad/s^2]; G a 4-tuple of rows
        ``(dx_i/dv_sd, dx_i/dv_sq)``; aux a dict with omega_s [rad/s], the currents,
        fluxes and inductances used (for diagnostics and the controller).
        """
        p, c = self.p, self._c
        phi, imd, imq, w = x[PHI_RD], x[I_MU_D], x[I_MU_Q], x[OMEGA]
        I = math.hypot(imd, imq)
        _, m, dm, ldyn = p.curve.evaluate(I)
        (dphi, Fd, Fq, Fw, a11, a12, a22, ws, Md, Mq, Mdq, isd, isq, psd, psq, te_J,
         det) = vector_fields(c, phi, imd, imq, w, m, dm, I, T_load / p.J, phi)
        F = (dphi, Fd, Fq, Fw)
        G = ((0.0, 0.0), (a11, a12), (a12, a22), (0.0, 0.0))
        aux = {"omega_s": ws, "i_sd": isd, "i_sq": isq, "psi_sd": psd, "psi_sq": psq,
               "T_e": te_J * p.J, "m": m, "dm_dI": dm, "L_dyn": ldyn, "M_d": Md, "M_q": Mq,
               "M_dq": Mdq, "det_L": det}
        return F, G, aux

    def derivatives_with_angle(self, t, xr, v_sd, v_sq, T_load):
        """Derivatives of ``[Phi_rd, i_mu_d, i_mu_q, omega_m, rho]`` with rho' = omega_s."""
        F, G, aux = self.fields(xr, T_load)
        return tuple(f + g[0] * v_sd + g[1] * v_sq for f, g in zip(F, G)) + (aux["omega_s"],)


def from_stationary(plant, x):
    """Flux-oriented state and flux angle from a stationary plant state.

    Returns ``((Phi_rd, i_mu_d, i_mu_q, omega_m), rho)`` with rho [rad] the angle of psi_r.
    """
    pra, prb = x[PSI_R_A], x[PSI_R_B]
    phi = math.hypot(pra, prb)
    rho = math.atan2(prb, pra)
    ima, imb, _, _, _ = plant.magnetizing(x[PSI_S_A], x[PSI_S_B], pra, prb)
    c, s = math.cos(rho), math.sin(rho)
    return (phi, c * ima + s * imb, -s * ima + c * imb, x[OMEGA_M]), rho


def to_stationary(params, x_fo, rho, theta_m=0.0):
    """Stationary plant state from a flux-oriented state, flux angle rho [rad] and theta_m [rad]."""
    phi, imd, imq, w = x_fo
    m = params.curve.m(math.hypot(imd, imq))
    ls_sm = params.l_s + params.sigma * m
    psd = ls_sm * imd - params.k * params.l_s / params.l_r * phi
    psq = ls_sm * imq
    c, s = math.cos(rho), math.sin(rho)
    x = [0.0] * N_STATES
    x[PSI_S_A], x[PSI_S_B] = c * psd - s * psq, s * psd + c * psq
    x[PSI_R_A], x[PSI_R_B] = c * phi, s * phi
    x[OMEGA_M], x[THETA_M] = w, theta_m
    return tuple(x)


__all__ = ["FluxOrientedModel", "ModelConstants", "model_constants", "vector_fields", "flux_rate",
           "from_stationary", "to_stationary", "PHI_RD", "I_MU_D", "I_MU_Q", "OMEGA"]

"""The seed's rotor-flux-oriented control model (section 3), in the corrected compact form.

State ``x = [Phi_rd, i_mu_d, i_mu_q, omega_m]`` ([Wb], [A], [A], [rad/s]) in the
frame rotating with the rotor flux (Phi_rq = 0); inputs ``v = [v_sd, v_sq]`` [V]
and the load torque ``T_load`` [N m]::

    x' = F(x) + G(x) v

Derivation (equivalent to seed eqs 24, 28-40 with the corrections of
``shared/design/errata.md``; the seed's coefficients a, b3, g0 divide by M_dq and
are singular at i_mu_q = 0, this form is not).  With ``sigma = 1 + k^2 l_s/l_r``,
``M`` the dynamic inductance matrix and ``L = l_s I2 + sigma M``::

    i_s   = (1 + k^2 m / l_r) i_mu - (k / l_r) Phi_rd e_d
    psi_s = (l_s + sigma m) i_mu - (k l_s / l_r) Phi_rd e_d
    Phi_rd' = (R_r / l_r)(k m i_mu_d - Phi_rd)                          (eq 24)
    omega_s = n_p omega_m + R_r k m i_mu_q / (l_r Phi_rd)               (eq 28)
    L i_mu' = v_s - R_s i_s - omega_s J2 psi_s + (k l_s / l_r) Phi_rd' e_d
    J omega_m' = kappa k m Phi_rd i_mu_q / l_r - T_load - B omega_m,  kappa = 3/2 n_p

The flux angle obeys ``rho' = omega_s``.
"""

from __future__ import annotations

import math

from .magnetics import dynamic_inductances
from .plant import N_STATES, OMEGA_M, PSI_R_A, PSI_R_B, PSI_S_A, PSI_S_B, THETA_M

PHI_RD, I_MU_D, I_MU_Q, OMEGA = range(4)
FO_STATE_NAMES = ("Phi_rd", "i_mu_d", "i_mu_q", "omega_m")


class FluxOrientedModel:
    """The control model ``x' = F(x) + G(x) v`` bound to one parameter set.

    Parameters
    ----------
    params : satmotor.params.MotorParams
    """

    def __init__(self, params):
        self.p = params
        self._sigma = params.sigma
        self._k2_lr = params.k * params.k / params.l_r
        self._k_lr = params.k / params.l_r
        self._kls_lr = params.k * params.l_s / params.l_r
        self._Rr_lr = params.R_r / params.l_r

    def fields(self, x, T_load):
        """Return ``(F, G, aux)`` at state ``x``.

        F is a 4-tuple [Wb/s, A/s, A/s, rad/s^2]; G a 4-tuple of rows
        ``(dx_i/dv_sd, dx_i/dv_sq)``; aux a dict with omega_s [rad/s], the currents,
        fluxes and inductances used (for diagnostics and the controller).
        """
        p = self.p
        phi, imd, imq, w = x[PHI_RD], x[I_MU_D], x[I_MU_Q], x[OMEGA]
        Md, Mq, Mdq, m, dm, ldyn = dynamic_inductances(p.curve, imd, imq)
        sg = self._sigma
        l11, l22, l12 = p.l_s + sg * Md, p.l_s + sg * Mq, sg * Mdq
        det = l11 * l22 - l12 * l12
        a11, a22, a12 = l22 / det, l11 / det, -l12 / det
        c = 1.0 + self._k2_lr * m
        isd = c * imd - self._k_lr * phi
        isq = c * imq
        ls_sm = p.l_s + sg * m
        psd = ls_sm * imd - self._kls_lr * phi
        psq = ls_sm * imq
        dphi = self._Rr_lr * (p.k * m * imd - phi)
        ws = p.n_p * w + self._Rr_lr * p.k * m * imq / phi
        r1 = -p.R_s * isd + ws * psq + self._kls_lr * dphi
        r2 = -p.R_s * isq - ws * psd
        te = 1.5 * p.n_p * p.k * m * phi * imq / p.l_r
        F = (dphi, a11 * r1 + a12 * r2, a12 * r1 + a22 * r2, (te - T_load - p.B * w) / p.J)
        G = ((0.0, 0.0), (a11, a12), (a12, a22), (0.0, 0.0))
        aux = {"omega_s": ws, "i_sd": isd, "i_sq": isq, "psi_sd": psd, "psi_sq": psq,
               "T_e": te, "m": m, "dm_dI": dm, "L_dyn": ldyn, "M_d": Md, "M_q": Mq,
               "M_dq": Mdq, "det_L": det}
        return F, G, aux

    def derivatives(self, t, x, v_sd, v_sq, T_load):
        """``x' = F(x) + G(x) v``."""
        F, G, _ = self.fields(x, T_load)
        return tuple(f + g[0] * v_sd + g[1] * v_sq for f, g in zip(F, G))

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


__all__ = ["FluxOrientedModel", "from_stationary", "to_stationary",
           "PHI_RD", "I_MU_D", "I_MU_Q", "OMEGA", "FO_STATE_NAMES"]

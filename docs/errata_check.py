"""Symbolic check of the errata in docs/errata.md (needs sympy, which the project does not depend on).

    pip install sympy && python docs/errata_check.py

The reference is derived here from first principles (flux linkages, the stator and rotor voltage
equations in the frame of the rotor flux), not from the seed's coefficient form. Each printed
equation is then compared with it, exactly, at random points with rational coordinates (i_mu is a
multiple of (3, 4), so |i_mu| is rational and nothing is rounded). Prints one line per claim; exit
status 1 if a claim of docs/errata.md does not hold.
"""

import random
import sys

import sympy as sp

m, mp, i_d, i_q, Phi, l_s, l_r, k, R_s, R_r, w_s, v_d, v_q, did, diq = sp.symbols(
    "m mp i_d i_q Phi l_s l_r k R_s R_r w_s v_d v_q did diq", real=True)
I = sp.sqrt(i_d**2 + i_q**2)
sigma = 1 + k**2 * l_s / l_r
e_d, J2 = sp.Matrix([1, 0]), sp.Matrix([[0, -1], [1, 0]])
i_mu = sp.Matrix([i_d, i_q])

# --- first principles: lambda = m(I) i_mu, psi_s = l_s i_s + lambda, psi_r = l_r i_r + k lambda
lam = m * i_mu
M_true = sp.Matrix([[m + mp * i_d**2 / I, mp * i_d * i_q / I], [mp * i_d * i_q / I, m + mp * i_q**2 / I]])
M_d, M_dq, M_q = M_true[0, 0], M_true[0, 1], M_true[1, 1]
i_r = (Phi * e_d - k * lam) / l_r                   # psi_r = (Phi, 0) in its own frame
i_s = i_mu - k * i_r
psi_s = l_s * i_s + lam
Phi_dot = -R_r * i_r[0]                              # rotor d axis: 0 = R_r i_rd + Phi'
L = l_s * sp.eye(2) + sigma * M_true                 # d psi_s/dt = L i_mu' - (k l_s/l_r) Phi' e_d
V = L * sp.Matrix([did, diq]) + R_s * i_s + w_s * J2 * psi_s - (k * l_s / l_r) * Phi_dot * e_d
detL = L.det()
Linv = sp.Matrix([[L[1, 1], -L[0, 1]], [-L[1, 0], L[0, 0]]]) / detL
x_dot = Linv * (sp.Matrix([v_d, v_q]) - V.subs({did: 0, diq: 0}))
did_true, diq_true = x_dot[0], x_dot[1]


def point(seed):
    r = random.Random(seed)

    def q(lo, hi):
        return sp.Rational(r.randint(lo, hi), 100)

    t = q(20, 150)
    return {m: q(5, 40), mp: -q(1, 5), i_d: 3 * t, i_q: 4 * t, Phi: q(30, 120), l_s: q(1, 9), l_r: q(1, 9),
            k: q(60, 120), R_s: q(50, 300), R_r: q(50, 300), w_s: q(-300, 300), v_d: q(-900, 900),
            v_q: q(-900, 900), did: q(-900, 900), diq: q(-900, 900)}


def equal(a, b, n=4):
    return all(sp.simplify((a - b).subs(point(s))) == 0 for s in range(n))


failures = []


def claim(text, holds):
    print(("holds   " if holds else "FAILS   ") + text)
    if not holds:
        failures.append(text)


# --- section 2 of the seed: the main-flux model
# a concrete curve: the arctan family's static inductance m(I) = L_inf + (L_0 - L_inf) atan(I/I_p) I_p / I
Is = sp.Symbol("I", positive=True)
m_curve = sp.Rational(1, 100) + sp.Rational(27, 100) * sp.atan(Is / 3) * 3 / Is
cross = sp.diff(m_curve.subs(Is, I) * i_d, i_q)               # d lambda_d / d i_mu_q
claim("eq 21: M_dq = d(m i_mu_d)/d i_mu_q = m' i_mu_d i_mu_q / I (no m term)",
      equal(cross, (sp.diff(m_curve, Is) * i_d * i_q / Is).subs(Is, I)))
claim("eq 21 as printed (m + m' i_mu_d i_mu_q / I) differs from it",
      not equal(cross, (m_curve + sp.diff(m_curve, Is) * i_d * i_q / Is).subs(Is, I)))
# phi_0 terms of eqs 5 and 9 with the corrected M: phi_d0 = lambda_d - M_d i_d - M_dq i_q (m = m(I))
mI = sp.Function("mf")(I)
Md_f = mI + sp.diff(mI, i_d) * i_d  # d(m i_d)/d i_d
Mq_f = mI + sp.diff(mI, i_q) * i_q
Mdq_f = sp.diff(mI * i_d, i_q)
phi_d0 = mI * i_d - Md_f * i_d - Mdq_f * i_q
phi_q0 = mI * i_q - Mq_f * i_q - Mdq_f * i_d
rhs15 = -sp.diff(Mq_f, i_d) * i_q - sp.diff(Mdq_f, i_d) * i_d
claim("eq 15: its right side is d phi_q0 / d i_mu_d", sp.simplify(sp.diff(phi_q0, i_d) - rhs15) == 0)
claim("eq 15: its right side is not d phi_d0 / d i_mu_d (the printed left side)",
      sp.simplify(sp.diff(phi_d0, i_d) - rhs15) != 0)
claim("eq 6 as printed", sp.simplify(sp.diff(phi_d0, i_d) + sp.diff(Md_f, i_d) * i_d
                                     + sp.diff(Mdq_f, i_d) * i_q) == 0)
claim("eq 7 as printed", sp.simplify(sp.diff(phi_d0, i_q) + sp.diff(Md_f, i_q) * i_d
                                     + sp.diff(Mdq_f, i_q) * i_q) == 0)
claim("eq 14 as printed", sp.simplify(sp.diff(phi_q0, i_q) + sp.diff(Mq_f, i_q) * i_q
                                      + sp.diff(Mdq_f, i_q) * i_d) == 0)
claim("det M = m L_dyn, L_dyn = m + m' I", equal(M_true.det(), m * (m + mp * I)))

# --- section 3: the coefficient form
a = (l_s + M_q * sigma) / (M_dq * sigma)
b1, b1p = R_s * (1 + k**2 * m / l_r), l_s + m + k**2 * l_s * m / l_r
b2 = -R_s * (1 + k**2 * m / l_r) + k**2 * l_s * m * R_r / l_r**2
b3p = -l_s - M_d * sigma
b3 = M_dq * sigma + a * b3p
b4, b4p = R_s * k / l_r - k * l_s * R_r / l_r**2, -k * l_s / l_r
g0 = 1 / M_dq * l_r / (k**2 * l_s + l_r)
comb = sp.expand(V[1] - a * V[0])
claim("eq 27 (with the corrected M_dq in a, b3): exact",
      equal(comb, b3 * did + (b1 + a * b1p * w_s) * i_q + (a * b2 + b1p * w_s) * i_d
            + (a * b4 + b4p * w_s) * Phi))
a_seed = (l_s + M_q * sigma) / ((M_dq + m) * sigma)  # a with the printed eq 21; V keeps the true M
claim("eq 27 with the printed M_dq (m added) in a: the i_mu_q' term does not cancel",
      not equal(sp.expand(V[1] - a_seed * V[0]).coeff(diq), 0))
did_29 = (-(b1 + a * b1p * w_s) * i_q - (a * b2 + b1p * w_s) * i_d - (a * b4 + b4p * w_s) * Phi
          - a * v_d + v_q) / b3
claim("eqs 29-30 with b'_2 read as b'_1 (b'_2 is never defined)", equal(did_true, did_29))
beta_bracket = (-(b1 + b1p * w_s) * i_q - (b2 + b1p * w_s) * i_d - (b4 + b4p * w_s) * Phi) / b3
claim("eqs 56, 60: the printed i_mu_d' bracket (no factors a) is not i_mu_d' at v = 0",
      not equal(beta_bracket, did_true.subs({v_d: 0, v_q: 0})))
claim("det L = (l_s + sigma m)(l_s + sigma L_dyn)",
      equal(detL, (l_s + sigma * m) * (l_s + sigma * (m + mp * I))))
# eqs 31-32: the split is the one of the compact form: d/dt i_mu = L^-1 (...), q row
Lqd, Lqq = Linv[1, 0], Linv[1, 1]
claim("L^-1 q row = (1/b3, g0 b3'/b3)", equal(Lqd, 1 / b3) and equal(Lqq, g0 * b3p / b3))
true_g = {"g1": b4 / b3, "g1'": -g0 * b3p * b4p / b3, "g2": b2 / b3, "g2'": -g0 * b3p * b1p / b3,
          "g3": -g0 * b3p * b1 / b3, "g3'": b1p / b3, "g4": 1 / b3, "g5": g0 * b3p / b3}
claim("eqs 31-32 with the coefficients of docs/errata.md reproduce di_mu_q/dt",
      equal(diq_true, (true_g["g1"] + true_g["g1'"] * w_s) * Phi + (true_g["g2"] + true_g["g2'"] * w_s) * i_d
            + (true_g["g3"] + true_g["g3'"] * w_s) * i_q + true_g["g4"] * v_d + true_g["g5"] * v_q))
printed_g = {"g1": g0 * b4 * (1 - b3p / b3), "g1'": -g0 * b3p * b4p / b3, "g2": g0 * b1p * (1 - b3p / b3),
             "g2'": -g0 * b3p * b1p / b3, "g3": -g0 * b3p * b1p / b3, "g3'": g0 * b1p * (1 - b3p / b3),
             "g4": 1 - a * b3p / b3, "g5": b3p / b3}
for name in ("g1'", "g2'"):
    claim(f"{name} as printed (b'_2 read as b'_1)", equal(printed_g[name], true_g[name]))
for name in ("g1", "g2", "g3", "g3'", "g4", "g5"):
    claim(f"{name} as printed is wrong", not equal(printed_g[name], true_g[name]))
claim("printed g4, g5 are the true ones times M_dq (k^2 l_s + l_r)/l_r",
      equal(printed_g["g4"], true_g["g4"] * M_dq * (k**2 * l_s + l_r) / l_r)
      and equal(printed_g["g5"], true_g["g5"] * M_dq * (k**2 * l_s + l_r) / l_r))
fixed_factor = g0 * (1 - a * b3p / b3)  # the printed (1 - b3'/b3) with the factor a
claim("printed g1, g2, g3' become right with (1 - a b3'/b3) for (1 - b3'/b3)",
      equal(b4 * fixed_factor, true_g["g1"]) and equal(b2 * fixed_factor, true_g["g2"])
      and equal(b1p * fixed_factor, true_g["g3'"]))
claim("no coefficient form is needed: a, b3 and g0 divide by M_dq, 0 at i_mu_q = 0",
      sp.simplify(M_dq.subs(i_q, 0)) == 0)

# --- section 4: the law
c1, e1, e2, Phi_ref1, Phi_ref2 = sp.symbols("c1 e1 e2 Phi_ref1 Phi_ref2")
alpha1 = -c1 * e1 + R_r / l_r * Phi + Phi_ref1
e1_dot = -c1 * e1 + e2                                # eq 47
alpha1_dot = -c1 * e1_dot + R_r / l_r * sp.Symbol("Phi_dot") + Phi_ref2
printed_55 = -c1 * e2 + c1 * e1**2 + R_r / l_r * sp.Symbol("Phi_dot") + Phi_ref2
claim("eq 55: alpha1' = -c1 e2 + c1^2 e1 + (R_r/l_r) Phi' + Phi_ref''",
      sp.expand(alpha1_dot - (-c1 * e2 + c1**2 * e1 + R_r / l_r * sp.Symbol("Phi_dot") + Phi_ref2)) == 0)
claim("eq 55 as printed (c1 e1^2) is wrong", sp.expand(alpha1_dot - printed_55) != 0)
# Lambda: e2 = K1 m i_d, z2 = K3 m i_q (seed: kappa = 1), so the v-coefficients of (e2', z2') are
# diag(K1, K3) M L^-1
K1, K3 = k * R_r / l_r, sp.Symbol("K3")
Lam = sp.diag(K1, K3) * M_true * Linv
Mdq_seed = M_dq + m                                   # the printed eq 21: the seed's (M_dq - m) = true M_dq
lam_printed = {
    "1": -K1 * (M_d * a / b3 - (Mdq_seed - m) * printed_g["g4"]),
    "2": K1 * (M_d / b3 + (Mdq_seed - m) * printed_g["g5"]),
    "3": -K3 * ((Mdq_seed - m) * a / b3 + M_q * printed_g["g4"]),
    "4": K3 * ((Mdq_seed - m) / b3 + M_q * printed_g["g5"]),
}
lam_fixed = {  # the same structure with the true g4, g5 and lambda3's sign corrected
    "1": -K1 * (M_d * a / b3 - M_dq * true_g["g4"]),
    "2": K1 * (M_d / b3 + M_dq * true_g["g5"]),
    "3": -K3 * (M_dq * a / b3 - M_q * true_g["g4"]),
    "4": K3 * (M_dq / b3 + M_q * true_g["g5"]),
}
true_lam = {"1": Lam[0, 0], "2": Lam[0, 1], "3": Lam[1, 0], "4": Lam[1, 1]}
for n in "1234":
    claim(f"lambda{n} as printed is wrong", not equal(lam_printed[n], true_lam[n]))
    claim(f"lambda{n} right with the true g4, g5" + (" and the sign of M_q g4 flipped" if n == "3" else ""),
          equal(lam_fixed[n], true_lam[n]))
claim("lambda3 with the true g4, g5 but the printed sign is still wrong",
      not equal(-K3 * (M_dq * a / b3 + M_q * true_g["g4"]), true_lam["3"]))
claim("W = det Lambda = K1 K3 m L_dyn / det L", equal(Lam.det(), K1 * K3 * m * (m + mp * I) / detL))
claim("eq 28 (omega_s): the rotor q equation with psi_rq = 0 gives omega + R_r k m i_mu_q / (l_r Phi)",
      equal(sp.Symbol("w") - R_r * i_r[1] / Phi, sp.Symbol("w") + R_r * k * m * i_q / (l_r * Phi)))
claim("eq 24: Phi' = (R_r/l_r)(k m i_mu_d - Phi)", equal(Phi_dot, R_r / l_r * (k * m * i_d - Phi)))
claim("eq 19: i_mu_q = i_sq + (k/l_r)(psi_rq - k (psi_sq - l_s i_sq))",
      equal(i_mu[1], i_s[1] + k / l_r * (0 - k * (psi_s[1] - l_s * i_s[1]))))

print(f"{len(failures)} claim(s) failed" if failures else "every claim holds")
sys.exit(1 if failures else 0)

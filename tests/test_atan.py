"""The arctan curve's own arc tangent (satmotor/machine/atan.py, fmu/native/core/sm_atan.c).

Against independent values: the exact arc tangent computed here in 60-digit decimal arithmetic
(argument halving and the Taylor series, pi from Machin's formula), the tables' entries and the
polynomial's coefficients from the same, and the platform's ``math.atan`` over 10^6 points.  The C
function against the Python bit for bit (ctypes), and the generated C header's table literals against the
Python's.  The arctan curve: its solve (which writes the atan's main branch out) and its evaluate (one
atan for psi, m, dm_dI) against the generic ones, and the C curve against the Python, bit for bit;
its solve with the own atan against the same Newton iteration written here with ``math.atan``: the
roots differ by less than the equation's rounding bound."""

from __future__ import annotations

import ctypes
import math
import random
import re
import shutil
import struct
import sys
from decimal import Decimal, localcontext
from fractions import Fraction
from pathlib import Path

import pytest

from satmotor.machine.atan import ACOT_K64, ATAN_K64, COEFFICIENTS, atan
from satmotor.machine.magnetics import ArctanCurve, _Curve

sys.path.insert(0, str(Path(__file__).resolve().parent))
import native_core as nc  # noqa: E402

from orchestration.packaging.native import atan_tables  # noqa: E402

SOURCE = Path(__file__).resolve().parents[1] / "fmu" / "native" / "core" / "sm_atan.c"
DIGITS = 60
SPECIAL = (0.0, -0.0, math.inf, -math.inf, 5e-324, -5e-324, 2.0**-28, -(2.0**-28), 2.0**-29, 0.0625,
           math.nextafter(0.0625, 0.0), 4.0, math.nextafter(4.0, 5.0), 2.0**60,
           math.nextafter(2.0**60, math.inf), 1.0, -1.0, 1.7976931348623157e308, -1.7976931348623157e308,
           1e-300, 1.5, 63.999999999999, 64.0)


def _pi():
    """pi = 16 atan(1/5) - 4 atan(1/239) (Machin), in the current decimal context."""
    def series(inv):
        x, term, total, n, sign = Decimal(1) / inv, Decimal(1) / inv, Decimal(0), 1, 1
        x2, eps = x * x, Decimal(10) ** -(DIGITS + 5)
        while term > eps:
            total += sign * term / n
            term *= x2
            n += 2
            sign = -sign
        return total
    return 16 * series(5) - 4 * series(239)


def exact_atan(x):
    """atan(x) to about 60 digits (Decimal); x a float or a Fraction."""
    with localcontext() as ctx:
        ctx.prec = DIGITS + 10
        v = Decimal(x) if not isinstance(x, Fraction) else Decimal(x.numerator) / Decimal(x.denominator)
        a = abs(v)
        if a == 0:
            return v
        big = a > 1
        if big:
            a = 1 / a
        for _ in range(3):  # atan(a) = 2 atan(a / (1 + sqrt(1 + a^2))): |a| <= tan(pi/32) < 0.1
            a = a / (1 + (1 + a * a).sqrt())
        term, total, n, sign, a2 = a, Decimal(0), 1, 1, a * a
        eps = a * Decimal(10) ** -(DIGITS + 5)  # relative to the first term
        while term > eps:
            total += sign * term / n
            term *= a2
            n += 2
            sign = -sign
        r = 8 * total
        if big:
            r = _pi() / 2 - r
        return -r if v < 0 else r


def ulps(y, exact):
    """|y - exact| in units of the last place of the double nearest to exact."""
    return float(abs(Decimal(y) - exact) / Decimal(math.ulp(float(exact))))


def points(n, seed):
    """n seeded points: the curve's range (|x| <= 8, most of them), the table's centres and midpoints,
    and a log-uniform spread over 1e-10..1e10 of both signs."""
    rnd = random.Random(seed)
    out = []
    for i in range(n):
        r = i % 5
        if r in (0, 1):
            x = rnd.uniform(0.0, 8.0)
        elif r == 2:
            x = (rnd.randrange(4, 257) + rnd.choice((-0.5, 0.5, 0.0)) + rnd.uniform(-1e-3, 1e-3)) / 64
        else:
            x = 10.0 ** rnd.uniform(-10, 10)
        out.append(x if rnd.random() < 0.9 else -x)
    return out


def same_bits(a, b):
    return struct.pack("<d", a) == struct.pack("<d", b)


def test_the_tables_are_the_arc_tangents_split_in_two_doubles():
    for k, (hi, lo) in enumerate(ATAN_K64):
        v = exact_atan(Fraction(k, 64))
        assert hi == float(v) and lo == float(v - Decimal(hi)), k
    with localcontext() as ctx:
        ctx.prec = DIGITS + 10
        half_pi = _pi() / 2
        for k, (hi, lo) in enumerate(ACOT_K64):
            v = half_pi - exact_atan(Fraction(k, 64))
            assert hi == float(v) and lo == float(v - Decimal(hi)), k
    assert COEFFICIENTS == tuple(float(Fraction((-1) ** n, 2 * n + 1)) for n in range(1, 8))
    assert len(ATAN_K64) == 257 and len(ACOT_K64) == 17


def test_within_0_62_ulp_of_the_exact_arc_tangent():
    """(The worst of 2 10^6 points, measured once against mpmath: 0.617 ulp at x = 0.1018.)"""
    worst, where = 0.0, None
    for x in points(20_000, 1) + list(SPECIAL[4:]):
        if math.isinf(x):
            continue
        e = ulps(atan(x), exact_atan(x))
        if e > worst:
            worst, where = e, x
    print(f"worst error of atan: {worst:.4f} ulp at x = {where!r}")
    assert worst <= 0.62, (worst, where)


def test_against_math_atan_over_a_million_points():
    """At most one ulp from the platform's libm (glibc's atan is within about half an ulp); the
    share of differing points is printed (run with -s)."""
    xs = points(1_000_000, 2)
    differ, worst, where = 0, 0.0, None
    for x in xs:
        y, ref = atan(x), math.atan(x)
        if y != ref:
            differ += 1
            e = abs(y - ref) / math.ulp(ref)
            if e > worst:
                worst, where = e, x
    print(f"atan differs from math.atan at {differ} of {len(xs)} points ({100 * differ / len(xs):.2f} %), "
          f"by at most {worst:g} ulp (at x = {where!r})")
    assert worst <= 1.0, (worst, where)
    assert differ < 0.05 * len(xs)


def test_special_values():
    assert same_bits(atan(0.0), 0.0) and same_bits(atan(-0.0), -0.0)
    assert atan(math.inf) == math.pi / 2 and atan(-math.inf) == -math.pi / 2
    assert math.isnan(atan(math.nan))
    assert atan(5e-324) == 5e-324 and atan(1e-300) == 1e-300
    assert atan(1.0) == math.pi / 4  # the double nearest to pi/4
    assert atan(2.0**61) == math.pi / 2
    rnd = random.Random(3)
    xs = [rnd.uniform(0.0, 10.0) for _ in range(1000)] + [10.0 ** rnd.uniform(-12, 12) for _ in range(1000)]
    for x in xs:
        assert same_bits(atan(-x), -atan(x))


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_c_equals_python_bit_for_bit():
    lib = nc.load()
    c_atan = lib.sm_atan
    rnd = random.Random(4)
    xs = points(100_000, 5) + list(SPECIAL) + [math.nan]
    xs += [struct.unpack("<d", struct.pack("<Q", rnd.getrandbits(64)))[0] for _ in range(50_000)]
    xs += [k / 64 + d for k in range(320) for d in (-2.0**-7, -1e-17, 0.0, 1e-17, 2.0**-7)]
    bad = [x for x in xs if not (same_bits(c_atan(x), atan(x)) or (math.isnan(x) and math.isnan(c_atan(x))))]
    assert not bad, (f"{len(bad)} of {len(xs)} differ, e.g. x = {bad[0]!r}: C {c_atan(bad[0])!r}, "
                     f"Python {atan(bad[0])!r}")


def test_the_generated_c_header_holds_the_python_tables(tmp_path):
    """The C reads its tables from sm_atan_tables.h, generated from atan.py: parsed back here, the
    same doubles; sm_atan.c itself holds no table literal (written once)."""
    text = atan_tables.write(tmp_path).read_text()
    hexfloat = r"-?0x[0-9a-f]+\.[0-9a-f]+p[+-]\d+"

    def table(name, n):
        body = re.search(rf"{name}\[{n}\]\[2\] = \{{(.*?)\n\}};", text, re.S).group(1)
        pairs = re.findall(rf"\{{({hexfloat}), ({hexfloat})\}}", body)
        return tuple((float.fromhex(h), float.fromhex(lo)) for h, lo in pairs)

    assert table("ATAN_K64", 257) == ATAN_K64
    assert table("ACOT_K64", 17) == ACOT_K64
    coef = tuple(float.fromhex(re.search(rf"#define SM_ATAN_C{n} \(?({hexfloat})\)?", text).group(1))
                 for n in range(1, 8))
    assert coef == COEFFICIENTS
    source = SOURCE.read_text()
    assert '#include "sm_atan_tables.h"' in source
    assert not re.search(hexfloat, source), "a hexadecimal literal in sm_atan.c: it belongs in atan.py"


def _solve_with_math_atan(curve, a, c):
    """ArctanCurve.solve's safeguarded Newton iteration (cold start) with the platform's math.atan."""
    L_inf, I_par = curve.L_m_inf, curve.I_par
    d = curve.L_m0 - L_inf
    lo, hi, x = 0.0, math.inf, c / (a + curve.L_m0)
    for _ in range(200):
        u = x / I_par
        g = a * x + L_inf * x + d * I_par * math.atan(u) - c
        if g == 0.0:
            return x
        if g > 0.0:
            hi = x
        else:
            lo = x
        x_new = x - g / (a + L_inf + d / (1.0 + u * u))
        if not lo < x_new < hi:
            x_new = 0.5 * (lo + hi) if hi < math.inf else 2.0 * x
        step, x = x_new - x, x_new
        if abs(step) <= 4e-16 * x:
            return x
    raise AssertionError("no convergence")


def test_the_curve_solve_moves_less_than_its_rounding_bound():
    """The root of a I + psi(I) = c with the own atan against the root with math.atan: within
    8 eps c / (a + L_dyn(I)), the change of I that a rounding of c alone would make (times 8)."""
    curve = ArctanCurve()
    rnd = random.Random(6)
    worst = 0.0
    for _ in range(20_000):
        a = rnd.choice((0.0, 10.0 ** rnd.uniform(-4, 1)))
        c = 10.0 ** rnd.uniform(-4, 1.3)
        got, _ = curve.solve(a, c)
        ref = _solve_with_math_atan(curve, a, c)
        bound = 8 * 2.0**-52 * c / (a + curve.L_dyn(ref))
        worst = max(worst, abs(got - ref) / bound)
    print(f"largest change of the root: {worst:.3f} of the rounding bound")
    assert worst <= 1.0


def _solve_cases(n, seed):
    """(a, c, guess): a = 0, the leakage-like 0.0165 and random; c over the flux range and tiny; guesses
    cold (0), near the root, far above and below it, nan and inf."""
    rnd = random.Random(seed)
    out = []
    for i in range(n):
        a = (0.0, 0.0165, rnd.uniform(0.0, 0.05), 10.0 ** rnd.uniform(-4, 1))[i % 4]
        c = rnd.uniform(0.0, 2.5) if i % 7 else 10.0 ** rnd.uniform(-12, 1)
        guess = (0.0, rnd.uniform(0.0, 40.0), 1e9, math.nan, math.inf, -1.0)[i % 6]
        out.append((a, c, guess))
    return out + [(0.01, 0.0, 0.0), (0.01, -1.0, 0.0), (0.0, 5e-324, 0.0), (0.0, 1e-300, 0.0)]


def test_the_written_out_solve_and_evaluate_equal_the_generic_ones():
    """ArctanCurve.solve (atan's main branch written out) against _Curve.solve on _psi_dpsi, and
    ArctanCurve.evaluate against psi, m, dm_dI, L_dyn one by one: the same floats."""
    for curve in (ArctanCurve(), ArctanCurve(L_m0=0.5, L_m_inf=0.2, I_par=0.7)):
        for a, c, guess in _solve_cases(20_000, 7):
            got, ref = curve.solve(a, c, guess), _Curve.solve(curve, a, c, guess)
            assert all(same_bits(x, y) for x, y in zip(got, ref)), (a, c, guess, got, ref)
        rnd = random.Random(8)
        for I in [0.0, 1e-300, 0.033, 0.0331, 1e3] + [rnd.uniform(0.0, 30.0) for _ in range(5000)]:
            psi, dpsi = curve._psi_dpsi(I)
            got, ref = curve.evaluate(I), (psi, curve.m(I), curve.dm_dI(I), dpsi)
            assert all(same_bits(x, y) for x, y in zip(got, ref)), (I, got, ref)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_the_c_arctan_curve_equals_the_python_bit_for_bit():
    """sm_curve_solve_from, sm_curve_evaluate, sm_curve_psi/m/dm_dI/L_dyn of the arctan curve against
    ArctanCurve: the same floats (the cross tests of test_native_core_plant.py allow 1e-12)."""
    lib = nc.load()
    D = ctypes.c_double
    for kw in ({}, {"L_m0": 0.5, "L_m_inf": 0.2, "I_par": 0.7}):
        py = ArctanCurve(**kw)
        c = nc.new_curve(lib)
        msg = ctypes.create_string_buffer(256)
        assert lib.sm_curve_init(c, b"arctan", py.L_m0, py.L_m_inf, py.I_par, 2.46, 7, b"", msg, 256) == 0
        I, psi = D(), D()
        for a, cc, guess in _solve_cases(10_000, 9):
            assert lib.sm_curve_solve_from(c, a, cc, guess, I, psi) == 0
            ref = py.solve(a, cc, guess)
            assert same_bits(I.value, ref[0]) and same_bits(psi.value, ref[1]), (a, cc, guess)
        rnd = random.Random(10)
        out = [D() for _ in range(4)]
        for x in [0.0, 1e-300, 0.033, 0.0331, 1e3, 7e20] + [rnd.uniform(0.0, 30.0) for _ in range(5000)]:
            lib.sm_curve_evaluate(c, x, *out)
            ref = py.evaluate(x)
            assert all(same_bits(o.value, r) for o, r in zip(out, ref)), (x, [o.value for o in out], ref)
            one = (lib.sm_curve_psi(c, x), lib.sm_curve_m(c, x), lib.sm_curve_dm_dI(c, x),
                   lib.sm_curve_L_dyn(c, x))
            ref = (py.psi(x), py.m(x), py.dm_dI(x), py.L_dyn(x))
            assert all(same_bits(o, r) for o, r in zip(one, ref)), x

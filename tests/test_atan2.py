"""The project's own atan2 (satmotor/machine/atan.py's ``atan2``, fmu/native/core/sm_atan.c's
``sm_atan2``), built on its own atan so that the controller's flux angle is the same float on every
platform.

Against independent values: C99's special cases (Annex F) against ``math.atan2`` bit for bit; the
error against the exact angle (60-digit decimal arithmetic of tests/test_atan.py) in every quadrant,
within the bound derived in the docstring of ``atan2`` (2 ulp); ``math.atan2`` (glibc) within that
bound plus glibc's own half ulp.  The C against the Python bit for bit at random arguments (ordinary
ones in every quadrant and random bit patterns)."""

from __future__ import annotations

import math
import random
import shutil
import struct
import sys
from decimal import Decimal, localcontext
from fractions import Fraction
from pathlib import Path

import pytest

from satmotor.machine.atan import atan2

sys.path.insert(0, str(Path(__file__).resolve().parent))
import native_core as nc  # noqa: E402
from test_atan import DIGITS, _pi, exact_atan, same_bits, ulps  # noqa: E402

ZEROS = (0.0, -0.0)
SIGNED = (1.0, -1.0, 5e-324, -5e-324, 1.7976931348623157e308, -1.7976931348623157e308, 0.3, -2.5e7)
INFS = (math.inf, -math.inf)


def exact_atan2(y, x):
    """The exact angle of (x, y) (finite, not both zero) as a Decimal."""
    with localcontext() as ctx:
        ctx.prec = DIGITS + 10
        pi = _pi()
        if x == 0.0:
            return pi / 2 if y > 0 else -pi / 2
        z = exact_atan(Fraction(abs(y)) / Fraction(abs(x)))
        r = z if x > 0 else pi - z
        return -r if y < 0 else r


def quadrant_points(n, seed):
    """(y, x) in every quadrant: the flux's scale (|.| <= 2 Wb), near the axes and the diagonals, and
    a log-uniform spread of both coordinates over 1e-150..1e150."""
    rnd = random.Random(seed)
    out = []
    for i in range(n):
        r = i % 4
        if r == 0:
            y, x = rnd.uniform(-2.0, 2.0), rnd.uniform(-2.0, 2.0)
        elif r == 1:
            a = rnd.uniform(-math.pi, math.pi) + rnd.choice((0.0, 1e-9, -1e-12))
            a = round(a / (math.pi / 4)) * (math.pi / 4) + rnd.uniform(-1e-6, 1e-6)
            y, x = math.sin(a), math.cos(a)
        else:
            y = rnd.choice((1.0, -1.0)) * 10.0 ** rnd.uniform(-150, 150)
            x = rnd.choice((1.0, -1.0)) * 10.0 ** rnd.uniform(-150, 150)
        out.append((y, x))
    return out


def test_special_cases_as_c99_and_math_atan2():
    cases = [(y, x) for y in ZEROS + SIGNED + INFS for x in ZEROS + SIGNED + INFS]
    for y, x in cases:
        assert same_bits(atan2(y, x), math.atan2(y, x)) or (
            y not in ZEROS + INFS and x not in ZEROS + INFS), (y, x, atan2(y, x), math.atan2(y, x))
    for y, x in ((math.nan, 1.0), (1.0, math.nan), (math.nan, math.nan), (math.inf, math.nan)):
        assert math.isnan(atan2(y, x))
    assert same_bits(atan2(0.0, -0.0), math.pi) and same_bits(atan2(-0.0, -0.0), -math.pi)
    assert same_bits(atan2(-0.0, 0.0), -0.0) and same_bits(atan2(-0.0, 5.0), -0.0)
    assert atan2(math.inf, -math.inf) == 3 * math.pi / 4 and atan2(-math.inf, math.inf) == -math.pi / 4
    assert atan2(1.0, 1.0) == math.pi / 4 and atan2(1.0, -1.0) == 3 * math.pi / 4  # rounded, as glibc


def test_within_2_ulp_of_the_exact_angle_and_of_math_atan2():
    worst, where, worst_lib = 0.0, None, 0.0
    for y, x in quadrant_points(8_000, 1):
        exact = exact_atan2(y, x)
        if abs(exact) < Decimal(2.0**-1000):
            continue  # subnormal angles: ulp(0) granularity, covered bit for bit by math.atan2 below
        e = ulps(atan2(y, x), exact)
        worst_lib = max(worst_lib, ulps(math.atan2(y, x), exact))
        if e > worst:
            worst, where = e, (y, x)
    print(f"worst error of atan2: {worst:.4f} ulp at {where!r}; math.atan2's: {worst_lib:.4f} ulp")
    assert worst <= 2.0, (worst, where)
    for y, x in quadrant_points(200_000, 2):
        ref = math.atan2(y, x)
        assert abs(atan2(y, x) - ref) <= 2.5 * math.ulp(ref), (y, x)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_c_equals_python_bit_for_bit():
    c_atan2 = nc.load().sm_atan2
    rnd = random.Random(4)

    def bits():
        return struct.unpack("<d", struct.pack("<Q", rnd.getrandbits(64)))[0]

    args = quadrant_points(100_000, 5) + [(bits(), bits()) for _ in range(50_000)]
    special = ZEROS + SIGNED + INFS + (math.nan,)
    args += [(y, x) for y in special for x in special]
    bad = [(y, x) for y, x in args if not (same_bits(c_atan2(y, x), atan2(y, x))
                                           or (math.isnan(atan2(y, x)) and math.isnan(c_atan2(y, x))))]
    assert not bad, (f"{len(bad)} of {len(args)} differ, e.g. {bad[0]!r}: C {c_atan2(*bad[0])!r}, "
                     f"Python {atan2(*bad[0])!r}")

"""Magnetizing characteristic from no-load test points, monotone cubic interpolation.

The points (i_mu [A], psi_m [Wb]) of a no-load test are interpolated with the
Fritsch-Carlson monotone piecewise-cubic Hermite scheme (PCHIP, the algorithm of
``scipy.interpolate.PchipInterpolator``; written out here because the physics
package depends on numpy only, and checked against scipy in the tests).  The data
are mirrored to negative currents before the slopes are computed, so the curve
is odd and its slope at the origin is the secant of the first segment.  Beyond
the last point the curve continues as a straight line with the end slope, so it
stays strictly increasing with a continuous derivative.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from satmotor.errors import ParameterError
from satmotor.machine.magnetics import _Curve


def _pchip_slopes(x, y):
    """Fritsch-Carlson knot slopes, as scipy's PchipInterpolator computes them."""
    h = np.diff(x)
    s = np.diff(y) / h
    d = np.zeros_like(x)
    w1 = 2.0 * h[1:] + h[:-1]
    w2 = h[1:] + 2.0 * h[:-1]
    same = (np.sign(s[1:]) == np.sign(s[:-1])) & (s[1:] != 0) & (s[:-1] != 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        harm = (w1 + w2) / (w1 / s[:-1] + w2 / s[1:])
    d[1:-1] = np.where(same, harm, 0.0)

    def edge(h0, h1, s0, s1):
        e = ((2.0 * h0 + h1) * s0 - h0 * s1) / (h0 + h1)
        if np.sign(e) != np.sign(s0):
            return 0.0
        if np.sign(s0) != np.sign(s1) and abs(e) > 3.0 * abs(s0):
            return 3.0 * s0
        return e

    d[0] = edge(h[0], h[1], s[0], s[1])
    d[-1] = edge(h[-1], h[-2], s[-1], s[-2])
    return d


@dataclass(frozen=True)
class TableCurve(_Curve):
    """Tabulated no-load characteristic, interpolated monotone and C1.

    Parameters
    ----------
    i_mu : tuple of float
        Magnetizing-current magnitudes [A], strictly increasing, >= 0.  A leading
        0 is added when absent.
    psi_m : tuple of float
        Main flux linkages [Wb] at those currents, strictly increasing, 0 at 0.
    source : str, optional
        Where the points came from (a file name), quoted in error messages.
    lines : tuple of int, optional
        The file line of each point, quoted in error messages.
    """

    i_mu: tuple
    psi_m: tuple
    source: str | None = None
    lines: tuple | None = field(default=None, repr=False, compare=False)
    name = "table"
    _x: tuple = field(init=False, repr=False, compare=False)
    _seg: tuple = field(init=False, repr=False, compare=False)
    _cum: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        x, y = self._validated()
        xm = np.concatenate([-x[:0:-1], x])
        ym = np.concatenate([-y[:0:-1], y])
        d = _pchip_slopes(xm, ym)[len(x) - 1 :]
        if not d[-1] > 0.0:
            s_last = (y[-1] - y[-2]) / (x[-1] - x[-2])
            s_prev = (y[-2] - y[-3]) / (x[-2] - x[-3])
            raise ParameterError(
                f"psi_m[{len(x) - 1}]", float(y[-1]),
                f"the monotone interpolation ends flat (end slope {float(d[-1])!r} H, must be > 0): the "
                f"last point{self._where(len(x) - 1)} (i_mu = {float(x[-1])!r}) rises with slope "
                f"{float(s_last):.4g} H, less than about a third of the slope {float(s_prev):.4g} H of the "
                "segment before; noisy points in saturation? smooth them (satmotor-cosim fit-curve "
                "writes a table that loads) or drop the last point",
                self.source,
            )
        segs, cum = [], [0.0]
        for k in range(len(x) - 1):
            h = x[k + 1] - x[k]
            s = (y[k + 1] - y[k]) / h
            c2 = (3.0 * s - 2.0 * d[k] - d[k + 1]) / h
            c3 = (d[k] + d[k + 1] - 2.0 * s) / (h * h)
            segs.append((float(x[k]), float(y[k]), float(d[k]), float(c2), float(c3)))
            cum.append(cum[-1] + y[k] * h + d[k] * h**2 / 2 + c2 * h**3 / 3 + c3 * h**4 / 4)
        segs.append((float(x[-1]), float(y[-1]), float(d[-1]), 0.0, 0.0))
        object.__setattr__(self, "_x", tuple(float(v) for v in x))
        object.__setattr__(self, "_seg", tuple(segs))
        object.__setattr__(self, "_cum", tuple(float(v) for v in cum))

    def _validated(self):
        src = self.source
        try:
            x = np.asarray(self.i_mu, dtype=float).ravel()
            y = np.asarray(self.psi_m, dtype=float).ravel()
        except (TypeError, ValueError):
            raise ParameterError("i_mu/psi_m", (self.i_mu, self.psi_m), "must be numbers", src) from None
        if x.size != y.size:
            raise ParameterError("psi_m", tuple(self.psi_m), f"has {y.size} points, i_mu has {x.size}", src)
        for name, v in (("i_mu", x), ("psi_m", y)):
            if not np.all(np.isfinite(v)):
                raise ParameterError(name, tuple(v.tolist()), "must be finite numbers", src)
            if np.any(v < 0):
                raise ParameterError(name, tuple(v.tolist()), "must be >= 0", src)
        if x.size and x[0] == 0.0:
            if y[0] != 0.0:
                raise ParameterError("psi_m", tuple(y.tolist()), "must be 0 at i_mu = 0", src)
        else:
            x, y = np.concatenate([[0.0], x]), np.concatenate([[0.0], y])
        if x.size < 3:
            raise ParameterError("i_mu", tuple(x.tolist()), "needs at least two points with i_mu > 0", src)
        for name, v in (("i_mu", x), ("psi_m", y)):
            bad = np.nonzero(np.diff(v) <= 0)[0]
            if bad.size:
                k = int(bad[0]) + 1
                what = ("i_mu must increase from point to point (sorted, no repeats)" if name == "i_mu"
                        else "psi_m must increase with i_mu")
                raise ParameterError(
                    f"{name}[{k}]", float(v[k]), f"{what}: point{self._where(k)} (i_mu = {float(x[k])!r}, "
                    f"psi_m = {float(y[k])!r}) is not above the previous one{self._where(k - 1)} "
                    f"(i_mu = {float(x[k - 1])!r}, psi_m = {float(y[k - 1])!r}); noisy no-load points? "
                    "make them monotone (satmotor-cosim fit-curve writes such a table)", src,
                )
        return x, y

    def _where(self, k):
        """Where point ``k`` of the validated points (which start at the origin) was given: `` on line
        N`` of the file, else `` N`` (1-based among the given points), `` 0 (the origin)``."""
        j = k - (0 if len(self.i_mu) and float(self.i_mu[0]) == 0.0 else 1)
        if self.lines and 0 <= j < len(self.lines):
            return f" on line {self.lines[j]}"
        return f" {j + 1}" if j >= 0 else " 0 (the origin, added)"

    @classmethod
    def from_csv(cls, path):
        """Read a two-column CSV (i_mu [A], psi_m [Wb]); a header line, blank lines and ``#`` comments
        are allowed.  Errors name the file and the line."""
        try:
            with open(path, encoding="utf-8-sig") as fh:
                text = fh.read()
        except (OSError, UnicodeDecodeError) as exc:
            raise ParameterError("table_file", str(path), f"cannot be read: {exc}") from None
        src, rows, lines = str(path), [], []
        for lineno, line in enumerate(text.splitlines(), start=1):
            cells = [c.strip() for c in line.split("#", 1)[0].split(",")]
            if cells == [""]:
                continue
            try:
                values = [float(c) for c in cells]
            except ValueError:
                if not rows and not lines:  # the header
                    lines.append(None)
                    continue
                values = None
            if values is None or len(values) != 2:
                raise ParameterError("table_file", f"line {lineno}: {line.strip()!r}",
                                     "must hold two numeric columns i_mu, psi_m", src)
            rows.append(values)
            lines.append(lineno)
        lines = [n for n in lines if n is not None]
        if not rows:
            raise ParameterError("table_file", src, "holds no points i_mu, psi_m", src)
        data = np.array(rows)
        return cls(tuple(data[:, 0].tolist()), tuple(data[:, 1].tolist()), source=src, lines=tuple(lines))

    @property
    def m0(self):
        return self._seg[0][2]

    def _locate(self, I):
        k = bisect.bisect_right(self._x, I) - 1
        return self._seg[k if k >= 0 else 0]

    def _psi_dpsi(self, I):
        x0, y0, d0, c2, c3 = self._locate(I)
        t = I - x0
        return y0 + t * (d0 + t * (c2 + t * c3)), d0 + t * (2.0 * c2 + 3.0 * t * c3)

    def m(self, I):
        if I < self._x[1]:
            _, _, d0, c2, c3 = self._seg[0]
            return d0 + I * (c2 + I * c3)
        return self._psi_dpsi(I)[0] / I

    def dm_dI(self, I):
        if I < self._x[1]:
            _, _, _, c2, c3 = self._seg[0]
            return c2 + 2.0 * c3 * I
        psi, ldyn = self._psi_dpsi(I)
        return (ldyn - psi / I) / I

    def coenergy(self, I):
        k = bisect.bisect_right(self._x, I) - 1
        k = max(k, 0)
        _, y0, d0, c2, c3 = self._seg[k]
        t = I - self._x[k]
        return self._cum[k] + t * (y0 + t * (d0 / 2 + t * (c2 / 3 + t * c3 / 4)))

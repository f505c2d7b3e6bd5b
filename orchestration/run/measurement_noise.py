"""Measurement noise and quantization between the plant and the controller.

A scenario's ``measurements:`` section (:class:`Measurements`, checked by
:mod:`orchestration.scenario.load`) names plant outputs that feed the controller
(:data:`orchestration.scenario.system.MEASUREMENTS`) with a Gaussian noise standard deviation and/or a
quantization step, in the signal's unit::

    measured = Q(clean + std * z),   Q(x) = step * floor(x / step + 1/2)   (no step: Q(x) = x)

(round to the nearest multiple of the step, halves upwards).  The master applies it at each
controller sample to the values it passes from the plant to the controller, after reading the clean
plant outputs; the plant itself never sees it.  The clean outputs keep their columns
(``plant.NAME``); each measured signal gets a column ``measured.NAME`` holding the value the
controller received at the last sample (held between samples when ``controller_every > 1``).

Draws: ``z`` comes from ``numpy.random.default_rng(seed).standard_normal``, one row per controller
sample, one column per signal with a noise ``std > 0`` in the order of
:data:`~orchestration.scenario.system.MEASUREMENTS`, read row-major.  The rows are drawn in blocks
(``block`` rows at a time, scaled by the standard deviations in numpy and turned into Python
floats once per block), so the per-sample path does float arithmetic only; the stream does not
depend on the block size, and the co-simulation master and the plain-Python reference
(:mod:`orchestration.run.reference`) use this same class, so they pass the controller the very same
floats.
"""

from __future__ import annotations

import math

__all__ = ["MeasurementNoise", "BLOCK_ROWS", "quantize"]

BLOCK_ROWS = 4096  # controller samples drawn at a time


def quantize(x, step):
    """``x`` rounded to the nearest multiple of ``step`` (> 0), halves upwards."""
    return step * math.floor(x / step + 0.5)


class MeasurementNoise:
    """The measured values of one run, sample after sample.

    ``spec``: :class:`Measurements`; ``names``: the plant output names in the order of the value
    sequences given to :meth:`__call__`.  Each call consumes one row of draws (one controller sample).
    """

    def __init__(self, spec, names, block=BLOCK_ROWS):
        import numpy as np  # here: reading and checking scenarios needs no numpy

        names = list(names)
        std = dict(spec.noise)
        step = dict(spec.quantization)
        self.signals = spec.signals
        self.columns = spec.columns
        noisy = [n for n in self.signals if std.get(n, 0.0) > 0]
        self._std = np.array([std[n] for n in noisy], dtype=float)
        # per measured signal: (index in the value sequence, column of its draw or -1, step or 0.0)
        self._ops = tuple((names.index(n), noisy.index(n) if n in noisy else -1, step.get(n, 0.0))
                          for n in self.signals)
        self._rng = np.random.default_rng(spec.seed)
        self._block = max(1, int(block))
        self._rows, self._next = [], 0

    @property
    def ops(self):
        """Per measured signal (order of :attr:`columns`): (index in the value sequence, column of its
        draw or -1, quantization step or 0.0)."""
        return self._ops

    @property
    def n_noisy(self):
        """The signals with a noise (columns of a row of draws)."""
        return len(self._std)

    def draw(self):
        """The next ``block`` rows of draws, scaled by the standard deviations (rows x
        :attr:`n_noisy`, float64); the compiled engine reads them as they are."""
        return self._rng.standard_normal((self._block, len(self._std))) * self._std

    def _refill(self):
        if len(self._std):
            self._rows = self.draw().tolist()
        else:
            self._rows = [()] * self._block
        self._next = 0

    def __call__(self, values):
        """``(measured, row)``: ``measured`` a list, ``values`` with the measured signals replaced;
        ``row`` the measured signals' values (order of :attr:`columns`)."""
        if self._next == len(self._rows):
            self._refill()
        z = self._rows[self._next]
        self._next += 1
        out = list(values)
        row = []
        for i, j, q in self._ops:
            x = out[i] + z[j] if j >= 0 else out[i]
            if q:
                x = q * math.floor(x / q + 0.5)  # quantize(), written out
            out[i] = x
            row.append(x)
        return out, row

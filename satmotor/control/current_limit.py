"""The current limit on the *measured* stator current: the law bounds its model's currents
(:mod:`satmotor.control.backstepping`, ``i_max``); this limiter lowers that bound while the measured
current exceeds ``I_max``.

In steady state, with the law's errors settled, the law's bound is a bound on the measured current
whatever the plant (the law's map from the measured i_s and psi_r to its magnetizing state inverts
the same relation its current demands are computed with).  It is not one where the errors do not
settle: a plant that needs more current than the law's model believes (a smaller magnetizing
inductance: a flux set-point the model reaches within I_max and the plant does not), transients, a
voltage limit, an uncompensated delay.  There the reduction ``i_red`` [A] integrates the excess::

    i_red <- clip(i_red + Ts gain (|i_s| - I_max), 0, (1 - CURRENT_FLOOR) I_max)
    bound  = I_max - i_red

so the measured current is brought back to I_max at the rate ``gain`` [1/s] (default 200 1/s: a time
constant of 5 ms at a law/model current ratio of 1, slower than the law's current loops, 1/c2 = 1 ms,
1/d2 = 2 ms), and the reduction unwinds at the same rate once the current is below I_max; the clip is
its anti-windup.  While ``i_red`` is 0 and the current below I_max nothing is computed: a run that
never exceeds I_max is unchanged, bit for bit.  With the bound at its floor and ``|i_s|`` still above
``CURRENT_WARN I_max`` the limit cannot be held (a load the drive cannot carry within I_max, a
set-point the plant cannot reach): a warning, once per run, in :attr:`CurrentLimiter.warnings`.
"""

from __future__ import annotations

from satmotor.errors import require_number

CURRENT_FLOOR = 0.1  # [1] the limiter leaves the law at least this share of I_max
CURRENT_WARN = 1.05  # [1] |i_s| above this share of I_max with the bound at its floor: a warning


def current_warning(i_meas, I_max):
    """The warning of a current limit the drive cannot hold (the C core writes the same text)."""
    return (f"the measured stator current |i_s| = {i_meas:.4g} A exceeds I_max = {I_max:.4g} A with the "
            f"law's current bound at its floor ({CURRENT_FLOOR:.4g} I_max): the current limit cannot be held "
            "(logged once per run)")


class CurrentLimiter:
    """The measured-current limiter (module docstring): ``I_max`` [A] > 0, ``gain`` [1/s] >= 0 (0: off,
    the bound stays I_max), ``Ts`` [s] > 0."""

    def __init__(self, I_max, gain, Ts):
        self.I_max = require_number("I_max", I_max, 0)
        self.gain = require_number("current_limit_gain", gain, 0, inclusive=True)
        self.Ts = require_number("Ts", Ts, 0)
        self._top = (1.0 - CURRENT_FLOOR) * self.I_max
        self.warnings = []  # messages for the host's log (the FMU glue takes them)
        self.reset()

    def reset(self):
        self.i_red = 0.0  # [A]
        self.warned = False

    def bound(self, i_meas):
        """The law's current bound [A] this sample from the measured ``|i_s|`` [A]."""
        I_max = self.I_max
        if self.gain > 0.0 and (self.i_red > 0.0 or i_meas > I_max):
            r = self.i_red + self.Ts * self.gain * (i_meas - I_max)
            self.i_red = min(max(r, 0.0), self._top)
            if self.i_red == self._top and i_meas > CURRENT_WARN * I_max and not self.warned:
                self.warned = True
                self.warnings.append(current_warning(i_meas, I_max))
        return I_max - self.i_red

    def get_state(self):
        return (self.i_red, float(self.warned))

    def set_state(self, s):
        self.i_red, self.warned = float(s[0]), bool(s[1])


__all__ = ["CURRENT_FLOOR", "CURRENT_WARN", "CurrentLimiter", "current_warning"]

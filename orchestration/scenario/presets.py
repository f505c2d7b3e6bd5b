"""``motor: {preset: NAME, ...overrides}``: a named motor of :mod:`satmotor.machine.library` in a scenario.

:func:`expand` turns the scenario's ``motor:`` and ``controller:`` sections into plain ones before
they are checked: the preset's motor parameters under the ones written beside ``preset``, the
preset's controller settings under the scenario's ``controller:`` section.  An unknown preset is a
problem naming ``motor.preset`` and the library's names.
"""

from __future__ import annotations

__all__ = ["expand", "PRESET_KEY"]

PRESET_KEY = "preset"


def expand(chk, raw_motor, raw_controller):
    """``(motor, controller)`` sections with the preset (if any) applied; problems go to ``chk``."""
    if not isinstance(raw_motor, dict) or PRESET_KEY not in raw_motor:
        return raw_motor, raw_controller
    from satmotor.machine.library import MOTORS

    name = raw_motor[PRESET_KEY]
    rest = {k: v for k, v in raw_motor.items() if k != PRESET_KEY}
    if not isinstance(name, str) or name not in MOTORS:
        chk.add(f"motor.{PRESET_KEY}", name,
                f"must be one of {', '.join(MOTORS)} (satmotor/machine/library.py)")
        return rest, raw_controller
    m = MOTORS[name]
    controller = raw_controller
    if raw_controller is None or isinstance(raw_controller, dict):
        controller = {**m.controller, **(raw_controller or {})}
    return {**m.values, **m.plant, **rest}, controller

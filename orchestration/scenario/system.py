"""The system a scenario runs: its units, how they connect, what the controller measures.

The units are ``plant``, ``controller`` and ``profile`` (the scenario's time profiles).  A
:class:`Connection` joins ``source`` to ``target``, each ``"unit.variable"``;
:data:`DEFAULT_CONNECTIONS` feed the controller the plant's measurements (:data:`MEASUREMENTS`,
derived from the interface tables) and the set-points, and the plant the controller's voltages and
the load.  :class:`Measurements` is a scenario's ``measurements:`` section (noise and quantization
of those signals, applied by the master: :mod:`orchestration.run.measurement_noise`).
"""

from __future__ import annotations

from dataclasses import dataclass

from satmotor.converter.dc_link import is_capacitor
from satmotor.interface import CONTROLLER_INPUTS, PLANT_OUTPUTS

__all__ = ["PLANT", "CONTROLLER", "PROFILE", "UNITS", "Connection", "MEASUREMENTS", "COLUMN_PREFIX",
           "DEFAULT_CONNECTIONS", "Measurements"]

PLANT, CONTROLLER, PROFILE = "plant", "controller", "profile"
UNITS = (PLANT, CONTROLLER, PROFILE)


@dataclass(frozen=True)
class Connection:
    """``source`` -> ``target``, each "unit.variable" with unit plant, controller or profile."""

    source: str
    target: str


# the DC-link voltage: the plant's output v_dc feeds the controller's input v_dc only when the scenario's
# plant has a capacitor link (connections_for); unconnected, the controller uses its parameter V_dc
LINK_VOLTAGE = "v_dc"
LINK_CONNECTION = Connection(f"plant.{LINK_VOLTAGE}", f"controller.{LINK_VOLTAGE}")
# the controller inputs the plant feeds (its measurements), in the controller FMU's input order
MEASUREMENTS = tuple(v.name for v in CONTROLLER_INPUTS
                     if v.name in {p.name for p in PLANT_OUTPUTS} and v.name != LINK_VOLTAGE)
COLUMN_PREFIX = "measured."  # recorded column of a measured signal (after noise): measured.NAME
DEFAULT_CONNECTIONS = tuple(
    [Connection(f"plant.{n}", f"controller.{n}") for n in MEASUREMENTS]
    + [Connection(f"profile.{n}", f"controller.{n}") for n in ("omega_ref", "psi_ref", "T_load")]
    + [Connection("controller.v_s_alpha", "plant.v_s_alpha"),
       Connection("controller.v_s_beta", "plant.v_s_beta"),
       Connection("profile.T_load", "plant.T_load")]
)


def link_on(plant_values):
    """Whether a scenario's plant parameters ``plant_values`` ({name: value}; None: none given) put its
    DC link on (``dc_link: capacitor``): its wiring, its metrics and the reference loop ask this."""
    return is_capacitor((plant_values or {}).get("dc_link"))


def connections_for(plant_values):
    """The connections of a scenario whose plant has the parameters ``plant_values``: the default ones,
    and the link voltage (plant ``v_dc`` -> controller ``v_dc``) when ``dc_link`` is ``capacitor``."""
    if link_on(plant_values):
        return DEFAULT_CONNECTIONS + (LINK_CONNECTION,)
    return DEFAULT_CONNECTIONS



@dataclass(frozen=True)
class Measurements:
    """A scenario's ``measurements:`` section, checked.  ``noise`` and ``quantization`` are
    ``((name, value), ...)`` in the order of :data:`MEASUREMENTS` (tuples: the scenario pickles)."""

    seed: int = 0
    noise: tuple[tuple[str, float], ...] = ()  # (name, std >= 0 in the signal's unit)
    quantization: tuple[tuple[str, float], ...] = ()  # (name, step > 0 in the signal's unit)

    @property
    def signals(self):
        """Names of the signals the section changes (a noise std > 0 or a quantization step), in the
        order of :data:`MEASUREMENTS`; empty: the section changes nothing."""
        named = {n for n, s in self.noise if s > 0} | {n for n, _ in self.quantization}
        return tuple(n for n in MEASUREMENTS if n in named)

    @property
    def columns(self):
        """Recorded column names of the measured signals."""
        return tuple(COLUMN_PREFIX + n for n in self.signals)

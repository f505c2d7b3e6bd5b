"""Connections of the co-simulation resolved once into named sources.

A :class:`~orchestration.scenario.system.Connection` joins ``source`` to ``target``, each
``"unit.variable"`` with unit ``plant``, ``controller`` or ``profile``.  :func:`resolve` turns
the connections feeding one FMU's inputs into one :class:`Source` per input, in the order of that
FMU's input port; the stepping loop then reads each input from its source with no name lookup.
"""

from __future__ import annotations

from typing import NamedTuple

from orchestration.scenario.system import CONTROLLER, PLANT, PROFILE, UNITS


class Source(NamedTuple):
    """Where one input takes its value: ``unit`` (PLANT or CONTROLLER: ``ref`` is the index in
    that unit's output port; PROFILE: ``ref`` is the profile's ``value(t)`` function)."""

    unit: str
    ref: object


def inputs_of(connections, unit):
    """Names of the ``unit`` variables that ``connections`` feed, in connection order."""
    return [c.target.split(".", 1)[1] for c in connections if c.target.startswith(unit + ".")]


def resolve(connections, unit, input_names, outputs, profiles):
    """One :class:`Source` per name of ``input_names`` (inputs of ``unit``).

    ``outputs``: ``{PLANT: names of the plant's output port, CONTROLLER: ...}``; ``profiles``:
    ``{name: value function}``.  A ValueError names an input nothing feeds or a source that does
    not exist.
    """
    by_target = {}
    for c in connections:
        src_unit = c.source.split(".", 1)[0]
        if src_unit not in UNITS or "." not in c.source:
            raise ValueError(f"connection {c.source} -> {c.target}: the source must be 'plant.NAME', "
                             "'controller.NAME' or 'profile.NAME'")
        by_target[c.target] = c.source
    out = []
    for name in input_names:
        src = by_target.get(f"{unit}.{name}")
        if src is None:
            raise ValueError(f"no connection feeds {unit}.{name}")
        src_unit, var = src.split(".", 1)
        if src_unit == PROFILE:
            if var not in profiles:
                raise ValueError(f"connection {src} -> {unit}.{name}: no profile {var!r}")
            out.append(Source(PROFILE, profiles[var]))
        else:
            names = outputs[src_unit]
            if var not in names:
                raise ValueError(f"connection {src} -> {unit}.{name}: {var!r} is not an output of the "
                                 f"{src_unit}")
            out.append(Source(PLANT if src_unit == PLANT else CONTROLLER, names.index(var)))
    return out

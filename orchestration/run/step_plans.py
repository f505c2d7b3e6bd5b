"""What the stepping loop calls every step, built once before the loop: the speed machinery of the
run layer, in one place (measured in bench/RESULTS.md, "Speed work", item 2).

* :func:`input_port` -- a unit's input port and the function that gathers its values from the
  plant's, the controller's and the profiles' value tuples: C-level picks (``itemgetter``) joined,
  one function per combination of feeding groups (no per-step branching on the wiring).
* :func:`evaluator` -- ``t -> (f1(t), f2(t), ...)`` for the profiles, a fixed-arity closure for up to
  four functions (no comprehension frame per step: 0.39 against 0.62 us for three profiles).
"""

from __future__ import annotations

from operator import itemgetter

from orchestration.run.fmu_instance import RealPort
from orchestration.run.wiring import inputs_of, resolve
from orchestration.scenario.system import CONTROLLER, PLANT, PROFILE

__all__ = ["input_port", "picker", "evaluator"]


def input_port(inst, unit, connections, outputs, profiles, prof):
    """The input port of ``unit`` and a function ``(plant values, controller values, profile values)
    -> the port's values``.  The port lists the inputs fed by the plant, then by the controller,
    then by profiles (``prof``: the value functions in recording order), so the values are the
    picks of the groups that feed the port, joined; the FMI call sets them all at once in that
    order."""
    names = inputs_of(connections, unit)
    srcs = resolve(connections, unit, names, outputs, profiles)
    groups = {PLANT: [], CONTROLLER: [], PROFILE: []}
    for name, s in zip(names, srcs):
        ref = s.ref if s.unit != PROFILE else next(i for i, f in enumerate(prof) if f is s.ref)
        groups[s.unit].append((name, ref))
    order = groups[PLANT] + groups[CONTROLLER] + groups[PROFILE]
    port = RealPort(inst, [name for name, _ in order])
    pick_p, pick_c, pick_f = (picker([ref for _, ref in groups[u]]) for u in (PLANT, CONTROLLER, PROFILE))
    fed = tuple(bool(groups[u]) for u in (PLANT, CONTROLLER, PROFILE))
    if fed == (True, False, True):  # the controller of the default connections

        def values(pv, cv, fv):
            return pick_p(pv) + pick_f(fv)
    elif fed == (False, True, True):  # the plant of the default connections

        def values(pv, cv, fv):
            return pick_c(cv) + pick_f(fv)
    else:

        def values(pv, cv, fv):
            return pick_p(pv) + pick_c(cv) + pick_f(fv)

    return port, values


def picker(indices):
    """``sequence -> tuple of sequence[i] for i in indices`` (one C-level call)."""
    if len(indices) >= 2:
        return itemgetter(*indices)
    if len(indices) == 1:
        i = indices[0]
        return lambda seq: (seq[i],)
    return lambda seq: ()


def evaluator(funcs):
    """``t -> tuple of f(t) for f in funcs`` without a comprehension's frame (the profiles, called
    once per step): fixed-arity closures for up to four functions."""
    if not funcs:
        return lambda t: ()
    if len(funcs) == 1:
        (a,) = funcs
        return lambda t: (a(t),)
    if len(funcs) == 2:
        a, b = funcs
        return lambda t: (a(t), b(t))
    if len(funcs) == 3:
        a, b, c = funcs
        return lambda t: (a(t), b(t), c(t))
    if len(funcs) == 4:
        a, b, c, d = funcs
        return lambda t: (a(t), b(t), c(t), d(t))
    return lambda t: tuple([f(t) for f in funcs])

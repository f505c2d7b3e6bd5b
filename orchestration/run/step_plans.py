"""What the stepping loop calls every step, built once before the loop: the speed machinery of the
run layer, in one place (measured in bench/RESULTS.md, "Speed work", item 2).

* :func:`input_port` -- a unit's input port and the function that gathers its values from the
  plant's, the controller's and the profiles' value tuples: C-level picks (``itemgetter``) joined,
  one function per combination of feeding groups (no per-step branching on the wiring).
* :func:`evaluator` -- ``t -> (f1(t), f2(t), ...)`` for the profiles, a fixed-arity closure for up to
  four functions (no comprehension frame per step: 0.39 against 0.62 us for three profiles).
* :func:`chained_port` -- a unit fed by one other unit's Real outputs and profiles only, wired through
  memory: the source's outputs are read (in an order chosen for it) into a buffer whose tail is the
  destination's input port, so the FMI set call reads them where the get call wrote them (no Python
  float per exchanged value; the Gauss-Seidel master's path).
"""

from __future__ import annotations

from ctypes import c_double, c_size_t
from operator import itemgetter
from typing import NamedTuple

from fmpy.fmi2 import fmi2ValueReference

from orchestration.run.fmu_instance import RealPort
from orchestration.run.wiring import inputs_of, resolve
from orchestration.scenario.system import CONTROLLER, PLANT, PROFILE

__all__ = ["input_port", "picker", "evaluator", "chained_port", "Chain"]


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


class Chain(NamedTuple):
    """:func:`chained_port`'s result.  ``get_args``: the source's fast get call writing its outputs into
    the buffer in the order ``order`` (indices of the source's output port); ``outputs``: the view of
    those values (the recorder copies it); ``set_args``: the destination's fast set call reading its
    whole input port from the buffer's tail; ``profiles``: the view of the port's profile-fed values
    and ``pick``: ``profile values -> those values`` (the loop writes them before each set)."""

    get_args: tuple
    outputs: object
    order: list
    set_args: tuple
    profiles: object
    pick: object


def chained_port(src, src_unit, src_names, dst, dst_unit, connections, outputs, profiles, prof):
    """The :class:`Chain` from the Real outputs ``src_names`` of ``src`` (unit ``src_unit``) to the
    inputs of ``dst`` (unit ``dst_unit``), or None when ``dst`` is fed by anything but those outputs
    (each at most once) and profiles.  The buffer holds the source's outputs, the ones feeding ``dst``
    last (in ``dst``'s port order), then the profile-fed inputs: ``dst``'s port is its last values."""
    names = inputs_of(connections, dst_unit)
    srcs = resolve(connections, dst_unit, names, outputs, profiles)
    fed = [(n, s.ref) for n, s in zip(names, srcs) if s.unit == src_unit]
    by_profile = [(n, next(i for i, f in enumerate(prof) if f is s.ref)) for n, s in zip(names, srcs)
                  if s.unit == PROFILE]
    if len(fed) + len(by_profile) != len(names) or len({i for _, i in fed}) != len(fed):
        return None
    fed_idx = [i for _, i in fed]
    order = [i for i in range(len(src_names)) if i not in set(fed_idx)] + fed_idx
    n_src, n_dst, n_prof = len(src_names), len(names), len(by_profile)
    buf = (c_double * (n_src + n_prof))()
    start = n_src - len(fed)  # dst's port: buf[start:]
    vr_src = (fmi2ValueReference * n_src)(*src.vr([src_names[i] for i in order]))
    vr_dst = (fmi2ValueReference * n_dst)(*dst.vr([n for n, _ in fed] + [n for n, _ in by_profile]))
    port = (c_double * n_dst).from_buffer(buf, 8 * start)
    get_args = (src.handle, vr_src, c_size_t(n_src), buf)
    set_args = (dst.handle, vr_dst, c_size_t(n_dst), port)
    if src.fmi3:
        get_args += (c_size_t(n_src),)
    if dst.fmi3:
        set_args += (c_size_t(n_dst),)
    return Chain(get_args, (c_double * n_src).from_buffer(buf), order, set_args,
                 (c_double * n_prof).from_buffer(buf, 8 * n_src), picker([i for _, i in by_profile]))

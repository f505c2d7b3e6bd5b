"""The co-simulation master: the plant and controller FMUs stepped together over a scenario.

* Time is ``t_k = t0 + k h`` (never accumulated); the controller is stepped every
  ``controller_every`` plant steps with ``dt = Ts``, the plant every ``h``.
* Connections are data (:data:`DEFAULT_CONNECTIONS`): plant outputs to controller inputs,
  controller voltages to plant inputs, profiles to inputs.
* Gauss-Seidel (default): at a sample the controller steps first, then the plant uses its new
  voltages.  Jacobi: the plant uses the voltages of the previous sample (both units see only
  values of the previous communication point), so the two orders differ by a one-sample delay
  that shrinks with the step.
* Row ``k`` of the record holds the plant outputs at ``t_k``, the controller outputs computed at
  ``t_k`` and the profiles at ``t_k``, as in :func:`satmotor.simulate.closed_loop`.
* An FMI discard, error or fatal status stops the run: what was recorded so far is kept, with the
  status, the time and the FMU's logged message.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import pandas as pd
from fmpy import extract
from fmpy.fmi1 import FMICallException

from .fmu_instance import STATUS, FMUInstance, RealPort

PLANT, CONTROLLER, PROFILE = "plant", "controller", "profile"


@dataclass(frozen=True)
class Connection:
    """``source`` -> ``target``, each "unit.variable" with unit plant, controller or profile."""

    source: str
    target: str


_MEAS = ("i_s_alpha", "i_s_beta", "psi_r_alpha", "psi_r_beta", "psi_s_alpha", "psi_s_beta", "omega_m")
DEFAULT_CONNECTIONS = tuple(
    [Connection(f"plant.{n}", f"controller.{n}") for n in _MEAS]
    + [Connection(f"profile.{n}", f"controller.{n}") for n in ("omega_ref", "psi_ref", "T_load")]
    + [Connection("controller.v_s_alpha", "plant.v_s_alpha"),
       Connection("controller.v_s_beta", "plant.v_s_beta"),
       Connection("profile.T_load", "plant.T_load")]
)


@dataclass
class RunResult:
    """Outcome of one run: the recorded rows and how the run ended."""

    scenario: object
    frame: pd.DataFrame
    status: str  # ok, discard, error, fatal (FMI status of the failing call), or 'setup'
    message: str
    t_end: float  # [s] last communication point reached (where a failure happened)
    wall_time: float  # [s]

    @property
    def ok(self):
        return self.status == "ok"


def _outputs(inst):
    return [v.name for v in inst.md.modelVariables if v.causality == "output"]


def _sources(conns, target_unit, port, plant_out, ctrl_out, profiles):
    """For each variable of ``port``: (kind, index-or-profile) of its connected source."""
    by_target = {c.target: c.source for c in conns}
    out = []
    for name in port.names:
        src = by_target.get(f"{target_unit}.{name}")
        if src is None:
            raise ValueError(f"no connection feeds {target_unit}.{name}")
        unit, var = src.split(".", 1)
        if unit == PLANT:
            out.append((0, plant_out.names.index(var)))
        elif unit == CONTROLLER:
            out.append((1, ctrl_out.names.index(var)))
        else:
            out.append((2, profiles[var]))
    return out


def _inputs(conns, unit):
    return [c.target.split(".", 1)[1] for c in conns if c.target.startswith(unit + ".")]


def run(scenario, plant_fmu, controller_fmu, connections=DEFAULT_CONNECTIONS, algorithm=None,
        unzip_dirs=None):
    """Run ``scenario`` (an :class:`orchestration.scenario.Scenario`) with the two FMU files.

    ``algorithm`` overrides the scenario's ('gauss-seidel' or 'jacobi'); ``unzip_dirs`` optional
    (plant, controller) extracted copies, to share between runs.  Never raises for an FMU failure:
    the :class:`RunResult` says what happened.
    """
    algorithm = algorithm or scenario.algorithm
    if algorithm not in ("gauss-seidel", "jacobi"):
        raise ValueError(f"algorithm = {algorithm!r}: must be gauss-seidel or jacobi")
    jacobi = algorithm == "jacobi"
    h, N, t0 = scenario.step, scenario.controller_every, 0.0
    n = round(scenario.stop_time / h)
    every = max(1, round(scenario.record.interval / h))
    profiles = {k: p.value for k, p in scenario.profiles.items()}
    ud = unzip_dirs or (extract(plant_fmu), extract(controller_fmu))
    wall0 = time.perf_counter()
    units, rows, names = [], [], ["time"]
    status, message, t_reached = "ok", "", t0
    current = None
    try:
        current = "plant"
        plant = FMUInstance(plant_fmu, "plant", ud[0])
        units.append(plant)
        current = "controller"
        ctrl = FMUInstance(controller_fmu, "controller", ud[1])
        units.append(ctrl)
        for inst, overrides in ((plant, scenario.plant), (ctrl, {**scenario.controller, "Ts": scenario.Ts})):
            current = inst.name
            inst.set_parameters(overrides)
            inst.initialize(t0)
        p_out, c_out = RealPort(plant, _outputs(plant)), RealPort(ctrl, _outputs(ctrl))
        p_in = RealPort(plant, _inputs(connections, PLANT))
        c_in = RealPort(ctrl, _inputs(connections, CONTROLLER))
        c_src = _sources(connections, CONTROLLER, c_in, p_out, c_out, profiles)
        p_src = _sources(connections, PLANT, p_in, p_out, c_out, profiles)
        prof_names = sorted(profiles)
        names += [f"plant.{v}" for v in p_out.names] + [f"controller.{v}" for v in c_out.names] + \
            [f"profile.{v}" for v in prof_names]
        pv, cv = p_out.read(), c_out.read()
        held = list(cv)  # controller outputs seen by the plant (Jacobi: one sample old); made once
        Ts = scenario.Ts
        for k in range(n + 1):
            t = t0 + k * h
            t_reached = t  # the plant state at t exists; a failure below happens at t
            if k % N == 0:
                current = "controller"
                for j, (kind, src) in enumerate(c_src):
                    c_in.values[j] = pv[src] if kind == 0 else (held[src] if kind == 1 else src(t))
                c_in.write()
                if jacobi:
                    held[:] = cv  # the previous sample's voltages, copied into the list made once
                ctrl.do_step(t, Ts)
                cv = c_out.read()  # the port's own array, refreshed in place
                if not jacobi:
                    held = cv
            if k % every == 0:
                rows.append([t, *pv, *cv, *(profiles[p](t) for p in prof_names)])
            if k == n:
                break
            current = "plant"
            for j, (kind, src) in enumerate(p_src):
                p_in.values[j] = held[src] if kind == 1 else (pv[src] if kind == 0 else src(t))
            p_in.write()
            plant.do_step(t, h)
            pv = p_out.read()
    except FMICallException as exc:
        inst = next((u for u in units if u.name == current), None)
        status = STATUS[exc.status] if 0 <= exc.status < len(STATUS) else str(exc.status)
        message = f"{current}: {exc}" + (f" -- {inst.last_message()}" if inst and inst.last_message() else "")
    except Exception as exc:  # noqa: BLE001 - instantiation, a bad override, a missing variable
        inst = next((u for u in units if u.name == current), None)
        status = "setup"
        message = f"{current}: {exc}" + (f" -- {inst.last_message()}" if inst and inst.last_message() else "")
    finally:
        for u in units:
            u.close()
    frame = pd.DataFrame(rows, columns=names)
    return RunResult(scenario, frame, status, message, t_reached, time.perf_counter() - wall0)

"""Complete the modelDescription.xml pythonfmu writes, so that other tools read the FMUs properly.

pythonfmu 0.7.0 writes no units, no default experiment, no version or license and no dependency
information.  :func:`complete` adds them, from the interface tables in ``satmotor.interface`` (the
single source of units and defaults), before the build computes the GUID from the content:

* ``<UnitDefinitions>``: one ``<Unit>`` per unit a Real variable of the FMU uses, named as in the
  interface table, with its SI ``<BaseUnit>`` exponents (:data:`SI_UNITS`; every unit is coherent
  SI, so no factor is needed); a ``unit`` attribute on each ``<Real>``.  ``A/Wb^n`` (the
  polynomial curve's coefficient ``poly_b``) has no fixed dimension (it depends on the Integer
  parameter ``poly_n``), so its ``<Unit>`` has no ``<BaseUnit>``: a tool may not convert it.
* ``<DefaultExperiment>``: start 0, step size the plant's ``h_int`` or the controller's ``Ts``
  default; stop time: the plant's is :data:`DEFAULT_STOP_TIME` (the default scenario's), the
  controller's is :data:`CONTROLLER_DEFAULT_SAMPLES` samples of ``Ts``.  The controller accepts only
  ``dt = Ts`` (one sample per step), and fmpy's ``simulate_fmu`` without options doubles the
  default step size until the experiment has at most 1000 steps: with 1.5 s it would step
  1.6 ms and the controller would discard its first step.  The plant accepts any step
  (``ceil(dt/h_int)`` RK4 sub-steps).  No ``tolerance``: both units step with a fixed step (RK4,
  one sample per step) and have no error control it could set.
* ``version`` (``satmotor.__version__``), ``license`` and ``copyright`` on ``fmiModelDescription``.
* ``<ModelStructure>`` that says the truth (FMI 2.0, section 2.2.8: for co-simulation the
  dependencies of an output are on the knowns *at a communication point*: the inputs set at that
  point, before any ``fmi2DoStep`` from it):

  - plant outputs are functions of the state only: ``dependencies=""`` (no direct feedthrough;
    the voltages act through the integration over the next step);
  - controller outputs are the voltages computed by the last ``fmi2DoStep`` from the inputs of the
    *previous* communication point (a sampled controller: sample at ``t``, hold over
    ``[t, t + Ts)``); inputs set at ``t`` change nothing until the next ``fmi2DoStep``, so they
    too have ``dependencies=""``.  Their dependence on past inputs is internal state, which the
    co-simulation ``dependencies`` do not describe.  This is what makes a loop of the two FMUs free
    of algebraic loops, whichever order a master steps them in.
  - initial values: the controller's outputs are exactly 0 until its first sample (``initial=
    "exact"``, start 0, as pythonfmu writes them).  The plant's outputs at the start are computed
    from the parameters (``omega_m0``, ``psi_r0`` and the motor: a magnetized start has non-zero
    fluxes and currents), so they become ``initial="calculated"`` (no start value) and are listed
    in ``<InitialUnknowns>`` with the parameters they are computed from (a superset: every motor
    parameter, ``omega_m0`` and ``psi_r0``; not the inputs, not ``h_int``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import satmotor
import satmotor.interface as itf

LICENSE = "MIT"
COPYRIGHT = "Copyright (c) 2026 the satmotor authors"  # the line of LICENSE
DEFAULT_STOP_TIME = 1.5  # [s] stop_time of the default scenario, scenarios/ramp_rated_load.yaml
CONTROLLER_DEFAULT_SAMPLES = 1000  # fmpy's default: at most 1000 output intervals, else doubled

# SI base-unit exponents of every unit in satmotor.interface; None: no fixed dimension
SI_UNITS = {
    "1": {},
    "s": {"s": 1},
    "1/s": {"s": -1},
    "Hz": {"s": -1},
    "1/s2": {"s": -2},
    "A": {"A": 1},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "Wb": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "Wb/s": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "V s/s": {"kg": 1, "m": 2, "s": -3, "A": -1},  # issue 35: flux_rate_max, a flux's rate (= Wb/s)
    "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "N m": {"kg": 1, "m": 2, "s": -2},
    "N m s": {"kg": 1, "m": 2, "s": -1},
    "N m s2/rad2": {"kg": 1, "m": 2, "rad": -2},
    "kg m2": {"kg": 1, "m": 2},
    "A/Wb^n": None,
    # the DC link (satmotor.converter.dc_link)
    "J": {"kg": 1, "m": 2, "s": -2},
    "F": {"kg": -1, "m": -2, "s": 4, "A": 2},
    # issue 19: core loss and the thermal model
    "W": {"kg": 1, "m": 2, "s": -3},
    "K": {"K": 1},
    "K/s": {"K": 1, "s": -1},  # the model-exchange plant's der(T_s), der(T_r)
    "V/s": {"kg": 1, "m": 2, "s": -4, "A": -1},  # its der(v_dc)
    "1/K": {"K": -1},
    "J/K": {"kg": 1, "m": 2, "s": -2, "K": -1},
    "K/W": {"kg": -1, "m": -2, "s": 3, "K": 1},
    # issue 35: the stray-load coefficient (torque k_stray |i_s|^2 omega_m)
    "N m s/(A2 rad)": {"kg": 1, "m": 2, "s": -1, "A": -2, "rad": -1},
}
_BASE_ORDER = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")

# per FMU: interface tables, the parameter giving the default step, the default stop time in steps
# (None: DEFAULT_STOP_TIME), and whether outputs are calculated at initialization (then: the
# parameters they are computed from; None: exact, start 0)
SPECS = {
    "SaturatedInductionMotor": (("PLANT_INPUTS", "PLANT_OUTPUTS", "PLANT_PARAMETERS"), "h_int", None,
                                tuple(v.name for v in itf.PLANT_PARAMETERS if v.name != "h_int")),
    "BacksteppingController": (("CONTROLLER_INPUTS", "CONTROLLER_OUTPUTS", "CONTROLLER_PARAMETERS"), "Ts",
                               CONTROLLER_DEFAULT_SAMPLES, None),
}


def variables(name):
    """The FMU's variables from the interface tables, in registration order."""
    return tuple(v for table in SPECS[name][0] for v in getattr(itf, table))


def output_initial_calculated(name):
    """True if the outputs of FMU ``name`` are calculated at initialization (no start value)."""
    return SPECS[name][3] is not None


def _num(x):
    return repr(float(x))


def complete(name, xml_bytes):
    """The model description ``xml_bytes`` of FMU ``name`` with units, default experiment, version,
    license and model structure (see the module docstring).  Deterministic."""
    _, step_param, n_steps, init_deps = SPECS[name]
    table = {v.name: v for v in variables(name)}
    root = ET.fromstring(xml_bytes)
    root.set("version", satmotor.__version__)
    root.set("license", LICENSE)
    root.set("copyright", COPYRIGHT)

    mv = root.find("ModelVariables")
    svs = list(mv)
    index = {sv.get("name"): i + 1 for i, sv in enumerate(svs)}
    if set(index) != set(table):
        raise ValueError(f"{name}: model variables {sorted(set(index) ^ set(table))} not in the interface")
    used = []
    for sv in svs:
        var, real = table[sv.get("name")], sv.find("Real")
        if real is None:
            continue
        if var.unit not in SI_UNITS:
            raise ValueError(f"{name}: unit {var.unit!r} of {var.name} has no SI definition")
        attrs = {"unit": var.unit, **real.attrib}
        real.attrib.clear()
        real.attrib.update(attrs)
        if var.unit not in used:
            used.append(var.unit)
        if init_deps is not None and var.causality == "output":
            sv.set("initial", "calculated")
            real.attrib.pop("start", None)

    units = ET.Element("UnitDefinitions")
    for u in used:
        unit = ET.SubElement(units, "Unit", {"name": u})
        if SI_UNITS[u] is not None:
            ET.SubElement(unit, "BaseUnit", {k: str(SI_UNITS[u][k]) for k in _BASE_ORDER if k in SI_UNITS[u]})
    children = list(root)
    root.insert(children.index(root.find("CoSimulation")) + 1, units)

    step = table[step_param].start
    experiment = ET.Element("DefaultExperiment", {
        "startTime": "0.0", "stopTime": _num(DEFAULT_STOP_TIME if n_steps is None else n_steps * step),
        "stepSize": _num(step)})
    root.insert(list(root).index(mv), experiment)

    old = root.find("ModelStructure")
    if old is not None:
        root.remove(old)
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [sv.get("name") for sv in svs if sv.get("causality") == "output"]
    out_el = ET.SubElement(ms, "Outputs")
    for n in outputs:
        ET.SubElement(out_el, "Unknown", {"index": str(index[n]), "dependencies": ""})
    if init_deps is not None:
        deps = " ".join(str(i) for i in sorted(index[p] for p in init_deps))
        init_el = ET.SubElement(ms, "InitialUnknowns")
        for n in outputs:
            ET.SubElement(init_el, "Unknown", {"index": str(index[n]), "dependencies": deps})

    ET.indent(root, space="\t")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True).replace(
        b"<?xml version='1.0' encoding='UTF-8'?>", b'<?xml version="1.0" encoding="UTF-8"?>', 1) + b"\n"

"""The clocked controller: an FMI 3.0 Scheduled Execution FMU of the native controller whose sampling
is a periodic input clock (``native-fmi3-clocked/BacksteppingController.fmu``).

The same C core, model (``fmu/controller/native_model.c``) and generated tables as the co-simulation
controller of ``native-fmi3/``, with the Scheduled Execution glue ``fmi3_se_glue.c`` (``fmu/native/fmi``,
model agnostic: the model only says its period, ``fg_model_clock.h``).  Its model description is the
co-simulation one (:func:`orchestration.packaging.native.model_description.fmi3`) with

* ``<ScheduledExecution>`` instead of ``<CoSimulation>`` (the same capability flags but those of
  co-simulation stepping);
* one ``<Clock>`` input, :data:`CLOCK` (value reference after ``time``), ``intervalVariability="constant"``,
  ``intervalDecimal`` the start value of ``Ts`` (so an importer reads the sample rate without running the
  FMU; the binary is compiled with the same number, ``-DFG_CLOCK_INTERVAL``, and refuses a ``Ts`` set to
  anything else at the end of initialization);
* every input and output clocked by it (``clocks``), Float64 ones ``variability="discrete"``: each
  activation at ``t`` reads the inputs set before it and writes the outputs, one sample, as a
  co-simulation step of ``Ts`` from ``t``.

Built by :func:`build_all` (``python -m orchestration build``); its tests are ``tests/test_clocked.py``.
"""

from __future__ import annotations

import hashlib
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from orchestration.packaging.native import fmus as native_fmus
from orchestration.packaging.native import model_description as nmd
from orchestration.packaging.native.compiler import GLUE_DIR, build_native_fmu, host_compiler, zig_available

NAME = "BacksteppingController"
DIR = "native-fmi3-clocked"
FILE = f"{NAME}.fmu"
CLOCK = "sample_clock"  # the clock's name in the model description
CLOCK_DESCRIPTION = "the controller's sampling: one sample per tick, a periodic clock of interval Ts"
GLUE = ("fmi3_se_glue.c",)
SE_FLAGS = ("needsExecutionTool", "canBeInstantiatedOnlyOncePerProcess", "canGetAndSetFMUState",
            "canSerializeFMUState")


def interval():
    """The clock's constant interval [s]: the start value of ``Ts``."""
    return float(nmd.sample_period_start())


def model_description(token="{GUID}"):
    """modelDescription.xml (bytes) of the clocked controller."""
    root = ET.fromstring(nmd.fmi3(NAME, token))
    children = list(root)
    cs = root.find("CoSimulation")
    se = ET.Element("ScheduledExecution", {"modelIdentifier": NAME,
                                           **{k: cs.get(k) for k in SE_FLAGS if cs.get(k) is not None}})
    root.remove(cs)
    root.insert(children.index(cs), se)
    mv = root.find("ModelVariables")
    clock_vr = str(1 + max(int(v.get("valueReference")) for v in mv))
    for v in mv:
        if v.get("causality") in ("input", "output"):
            v.set("clocks", clock_vr)
            v.set("variability", "discrete")
    ET.SubElement(mv, "Clock", {"name": CLOCK, "valueReference": clock_vr, "description": CLOCK_DESCRIPTION,
                                "causality": "input", "variability": "discrete",
                                "intervalVariability": "constant", "intervalDecimal": repr(interval())})
    return nmd._xml(root)


def clock_value_reference():
    root = ET.fromstring(model_description())
    return int(root.find(f"ModelVariables/Clock[@name='{CLOCK}']").get("valueReference"))


def extra_cflags():
    """The Scheduled Execution build's ``-D`` flags: the glue's mode, the clock's value reference and
    interval (the same numbers as the model description)."""
    return ("-DFG_SCHEDULED_EXECUTION", f"-DFG_CLOCK_VR={clock_value_reference()}",
            f"-DFG_CLOCK_INTERVAL={interval()!r}")


def inputs_fingerprint():
    """SHA-256 over what the clocked FMU is built from: the co-simulation controller's inputs and this
    module."""
    h = hashlib.sha256(native_fmus.inputs_fingerprint(NAME).encode())
    h.update(Path(__file__).read_bytes())
    return h.hexdigest()


def path(out_dir):
    return Path(out_dir) / DIR / FILE


def documentation(xml):
    from orchestration.packaging.documentation import documentation as page

    se = ET.fromstring(xml).find("ScheduledExecution")
    flags = {k: v for k, v in se.attrib.items() if k != "modelIdentifier"}
    intro = (f"{nmd.UNIT_DESCRIPTION[NAME].rstrip('.')}. Native C implementation as an FMI 3.0 Scheduled "
             f"Execution FMU: its sampling is the periodic input clock {CLOCK} (intervalVariability "
             f"constant, interval Ts = {interval()!r} s); each activation runs one sample, bit for bit the "
             "co-simulation controller's step of Ts.")
    return page(NAME, flags=flags, intro=intro).encode("utf-8")


def build(out_dir, platforms=None, resources=None):
    """Build the clocked controller into ``out_dir/native-fmi3-clocked/``; returns its path."""
    xml = model_description().decode("utf-8")
    target = path(out_dir)
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="sm_vars_se_") as tmp:
        plats = platforms or native_fmus.LINUX["3.0"]
        portable = len(plats) > 1 or (host_compiler() is None and zig_available())
        built, _ = build_native_fmu(
            NAME, [*native_fmus.sources(NAME), *(GLUE_DIR / g for g in GLUE),
                   *native_fmus.generated(NAME, tmp)],
            xml, target, "3.0", plats,
            resources={**(resources or {}), native_fmus.BUILD_INPUTS: (inputs_fingerprint() + "\n").encode()},
            extra_cflags=extra_cflags(), linux_glibc=native_fmus.PORTABLE_GLIBC if portable else None,
            documentation={"index.html": documentation(xml)},
            extra_files={nmd.TERMINALS_FILE: nmd.terminals_and_icons(NAME)})
    return built


def build_all(out_dir, cross=False):
    """The clocked controller (``cross``: for every FMI 3.0 platform of :data:`native_fmus.ALL` too)."""
    cross = zig_available() if cross is None else cross
    return [build(out_dir, (native_fmus.ALL if cross else native_fmus.LINUX)["3.0"])]


def up_to_date(out_dir, all_platforms=False):
    """True when the clocked FMU exists, built from the current sources (and, with ``all_platforms``,
    for every platform)."""
    import zipfile

    try:
        with zipfile.ZipFile(path(out_dir)) as z:
            ok = z.read("resources/" + native_fmus.BUILD_INPUTS).decode().strip() == inputs_fingerprint()
            folders = {n.split("/")[1] for n in z.namelist()
                       if n.startswith("binaries/") and n.count("/") >= 2}
    except (OSError, KeyError, zipfile.BadZipFile):
        return False
    return ok and (not all_platforms or set(native_fmus.ALL["3.0"]) <= folders)

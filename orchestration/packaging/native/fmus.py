"""Build the native (C, Python-free) FMUs of the plant and the controller, FMI 2.0 and FMI 3.0.

Each FMU is the model-agnostic glue (``fmu/native/fmi``), the C core (``fmu/native/core``) with its
generated parameter structs (``sm_params.h`` / ``.c``), the shared value accessors
(``fmu/native/common/sm_values.c``), the unit's model (``fmu/plant/native_model.c`` or
``fmu/controller/native_model.c``) and its generated tables ``sm_vars.h`` / ``sm_vars.c``: all
generated from the interface tables by :mod:`orchestration.packaging.native.tables`; the model description
comes from the same tables (:mod:`orchestration.packaging.native.model_description`).  Compiled and packed by
:func:`orchestration.packaging.native.compiler.build_native_fmu` (reproducible; the GUID is derived from the
inputs).

Layout under the build directory: ``native/<Name>.fmu`` (FMI 2.0) and ``native-fmi3/<Name>.fmu``
(FMI 3.0).
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from orchestration.packaging.native import model_description as nmd
from orchestration.packaging.native.compiler import GLUE_DIR, build_native_fmu, host_compiler, zig_available
from orchestration.packaging.native.tables import core_files, model_files

FMU_DIR = GLUE_DIR.parents[1]  # the FMU sources (installed package or the checkout's fmu/)
BUILD_INPUTS = "build_inputs.sha256"  # in resources/: what the FMU was built from
NAMES = {"SaturatedInductionMotor": "plant", "BacksteppingController": "controller"}
DIRS = {"2.0": "native", "3.0": "native-fmi3"}
LINUX = {"2.0": ("linux64",), "3.0": ("x86_64-linux",)}
PORTABLE_GLIBC = "2.17"  # with zig: the Linux binary runs on glibc 2.17 and later (gcc here: 2.29)
ALL = {"2.0": ("linux64", "win64", "darwin64"), "3.0": ("x86_64-linux", "x86_64-windows", "x86_64-darwin",
                                                         "aarch64-darwin")}


def sources(name):
    """The C files of the native FMU ``name`` besides the glue and the generated files
    (:func:`generated`)."""
    core = sorted((FMU_DIR / "native" / "core").glob("*.[ch]"))
    common = sorted((FMU_DIR / "native" / "common").glob("*.[ch]"))
    return [*core, *common, FMU_DIR / NAMES[name] / "native_model.c"]


def generated(name, out_dir):
    """Write the generated C of the native FMU ``name`` into ``out_dir`` (the core's ``sm_params.h``
    / ``.c``, the model's ``sm_vars.h`` / ``.c``); returns the paths."""
    return [*core_files(out_dir), *model_files(name, out_dir)]


def inputs_fingerprint(name):
    """SHA-256 over everything the native FMU ``name`` is built from: its C sources, the glue, the
    interface tables and the generators (a change to any makes a built FMU stale)."""
    from orchestration.packaging import documentation as documentation_module
    from orchestration.packaging import fmu_model_description
    from orchestration.packaging import sources as sources_module
    from orchestration.packaging.native import compiler as native_build
    from orchestration.packaging.native import source_fmu
    from orchestration.packaging.native import tables as native_tables
    from satmotor import interface

    h = hashlib.sha256()
    files = [*sources(name), *sorted(GLUE_DIR.glob("*.[ch]")), Path(__file__), Path(native_build.__file__),
             Path(source_fmu.__file__),
             *native_tables.GENERATOR_FILES, Path(nmd.__file__), Path(fmu_model_description.__file__),
             Path(interface.__file__), Path(sources_module.__file__), Path(documentation_module.__file__)]
    for f in files:
        h.update(f.name.encode() + b"\0" + Path(f).read_bytes() + b"\0")
    return h.hexdigest()


def build(name, out_dir, fmi_version="2.0", platforms=None, resources=None):
    """Build the native FMU ``name`` into ``out_dir/native[-fmi3]/``; returns its path.  ``resources``:
    extra files ``{name: bytes}`` for ``resources/`` (e.g. a ``table`` curve's CSV: a ``table_file``
    that does not exist as given is looked up there by its base name)."""
    xml = (nmd.fmi2 if fmi_version == "2.0" else nmd.fmi3)(name).decode("utf-8")
    doc = documentation(name, xml, fmi_version)
    target = Path(out_dir) / DIRS[fmi_version] / f"{name}.fmu"
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="sm_vars_") as tmp:
        plats = platforms or LINUX[fmi_version]
        # the distributable build (several platforms) links the Linux binary against an old glibc with zig;
        # so does a Linux-only build on a machine without gcc or cc
        portable = len(plats) > 1 or (host_compiler() is None and zig_available())
        path, _ = build_native_fmu(name, [*sources(name), *generated(name, tmp)], xml, target, fmi_version,
                                   plats,
                                   resources={**(resources or {}),
                                              BUILD_INPUTS: (inputs_fingerprint(name) + "\n").encode()},
                                   linux_glibc=PORTABLE_GLIBC if portable else None,
                                   documentation={"index.html": doc},
                                   extra_files={nmd.TERMINALS_FILE: nmd.terminals_and_icons(name)}
                                   if fmi_version != "2.0" and name in nmd.TERMINALS else None)
    return path


def documentation(name, xml, fmi_version):
    """``documentation/index.html`` of the native FMU ``name``: the pythonfmu FMU's page (the same
    variables, from the same tables) with the capability flags of this model description ``xml``."""
    import xml.etree.ElementTree as ET

    from orchestration.packaging.documentation import documentation as page

    cs = ET.fromstring(xml).find("CoSimulation")
    flags = {k: v for k, v in cs.attrib.items() if k != "modelIdentifier"}
    intro = (f"{nmd.UNIT_DESCRIPTION[name].rstrip('.')}. Native C implementation (FMI {fmi_version} "
             "co-simulation, no Python needed), built from fmu/native/ and tested equal to the Python "
             "package satmotor, which the pythonfmu FMU of the same name runs.")
    return page(name, flags=flags, intro=intro).encode("utf-8")


def build_all(out_dir, cross=False):
    """Both native co-simulation FMUs in both FMI versions (the model-exchange plant is
    :func:`orchestration.packaging.native.model_exchange.build_all`); returns the paths.  For this
    machine (Linux x86_64) by default; ``cross``: also Windows and macOS (:data:`ALL`, cross-compiled
    with zig cc, which the ``ziglang`` wheel provides; on a fresh machine zig first compiles its MinGW
    and macOS C runtimes: minutes).  ``cross=None``: cross when zig is installed."""
    cross = zig_available() if cross is None else cross
    return [build(name, out_dir, version, (ALL if cross else LINUX)[version])
            for version in DIRS for name in NAMES]

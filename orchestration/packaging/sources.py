"""Where the FMU sources are, and what each pythonfmu FMU is made of.

The sources (``fmu/``: the pythonfmu slaves, the glue, the native C) are installed with the package
as ``satmotor_fmu_sources``, so an installed ``satmotor-cosim`` builds the FMUs outside a checkout
too.  :data:`FMUS` names, per FMU, its slave script, the interface tables it registers, the modules
whose docstrings hold its equations and its pythonfmu capability flags.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import satmotor

__all__ = ["fmu_sources", "SOURCES", "SATMOTOR", "GLUE", "FMUS", "COMMON_OPTIONS"]


def fmu_sources():
    """The directory of the FMU sources: the installed ``satmotor_fmu_sources`` (in a checkout with
    an editable install, that is ``fmu/``), else the checkout's ``fmu/``."""
    spec = importlib.util.find_spec("satmotor_fmu_sources")
    if spec is not None and spec.origin:
        return Path(spec.origin).resolve().parent
    return Path(__file__).resolve().parents[2] / "fmu"


SOURCES = fmu_sources()
SATMOTOR = Path(satmotor.__file__).resolve().parent
GLUE = SOURCES / "common" / "satmotor_fmu_glue.py"
SOURCES = fmu_sources()
SATMOTOR = Path(satmotor.__file__).resolve().parent
GLUE = SOURCES / "common" / "satmotor_fmu_glue.py"

# name: (slave script, interface table names, modules whose docstrings hold the equations, build options)
FMUS = {
    "SaturatedInductionMotor": (
        SOURCES / "plant" / "satmotor_plant_fmu.py",
        ("PLANT_INPUTS", "PLANT_OUTPUTS", "PLANT_PARAMETERS"),
        ("satmotor.machine.plant", "satmotor.machine.magnetics", "satmotor.machine.table_curve"),
        {"canHandleVariableCommunicationStepSize": True},
    ),
    "BacksteppingController": (
        SOURCES / "controller" / "satmotor_controller_fmu.py",
        ("CONTROLLER_INPUTS", "CONTROLLER_OUTPUTS", "CONTROLLER_PARAMETERS"),
        ("satmotor.control.fo_model", "satmotor.control.backstepping", "satmotor.control.drive",
         "satmotor.control.references", "satmotor.control.ifoc"),
        {"canHandleVariableCommunicationStepSize": False},
    ),
}
COMMON_OPTIONS = {"canGetAndSetFMUstate": True, "canSerializeFMUstate": True, "needsExecutionTool": True}

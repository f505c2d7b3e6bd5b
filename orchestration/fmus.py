"""Where the FMUs are, whether they match the current sources, and building them.

The orchestration never imports the FMU code: it runs :mod:`orchestration.fmu_build` in a child
process and compares the fingerprint of the build inputs it wrote into each FMU
(``resources/build_inputs.sha256``) with the current sources.
"""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

DEFAULT_DIR = Path("build") / "fmus"  # relative to the working directory
PLANT, CONTROLLER = "SaturatedInductionMotor.fmu", "BacksteppingController.fmu"


def paths(fmu_dir=DEFAULT_DIR):
    """(plant, controller) FMU paths in ``fmu_dir``."""
    d = Path(fmu_dir)
    return d / PLANT, d / CONTROLLER


def up_to_date(fmu_dir=DEFAULT_DIR):
    """True when both FMUs exist and were built from the current sources: satmotor, the glue, the
    slave scripts and the build logic (:func:`orchestration.fmu_build.inputs_fingerprint`)."""
    from .fmu_build import BUILD_INPUTS, inputs_fingerprint

    for p in paths(fmu_dir):
        try:
            with zipfile.ZipFile(p) as z:
                built = z.read(BUILD_INPUTS).decode().strip()
        except (OSError, KeyError, zipfile.BadZipFile):
            return False
        if built != inputs_fingerprint(p.stem):
            return False
    return True


def build(fmu_dir=DEFAULT_DIR, quiet=False):
    """Build both FMUs into ``fmu_dir``; raises CalledProcessError when the build fails."""
    subprocess.run([sys.executable, "-m", "orchestration.fmu_build", "--out", str(fmu_dir)], check=True,
                   stdout=subprocess.DEVNULL if quiet else None)
    return paths(fmu_dir)


def ensure(fmu_dir=DEFAULT_DIR, quiet=False):
    """The FMU paths, built first when missing or stale."""
    if not up_to_date(fmu_dir):
        build(fmu_dir, quiet)
    return paths(fmu_dir)

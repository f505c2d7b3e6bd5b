"""Where the FMUs are, whether they match the current sources, and building them.

The orchestration never imports the FMU code: it runs :mod:`orchestration.fmu_build` in a child
process and reads the fingerprint the build baked into each slave script.
"""

from __future__ import annotations

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import satmotor

DEFAULT_DIR = Path("build") / "fmus"  # relative to the working directory
PLANT, CONTROLLER = "SaturatedInductionMotor.fmu", "BacksteppingController.fmu"
_SLAVES = {PLANT: "resources/satmotor_plant_fmu.py", CONTROLLER: "resources/satmotor_controller_fmu.py"}


def paths(fmu_dir=DEFAULT_DIR):
    """(plant, controller) FMU paths in ``fmu_dir``."""
    d = Path(fmu_dir)
    return d / PLANT, d / CONTROLLER


def built_fingerprint(fmu_path, slave):
    """The satmotor fingerprint baked into an FMU, or None."""
    try:
        with zipfile.ZipFile(fmu_path) as z:
            text = z.read(slave).decode("utf-8")
    except (OSError, KeyError, zipfile.BadZipFile):
        return None
    m = re.search(r'FINGERPRINT = "([0-9a-f]{64})"', text)
    return m.group(1) if m else None


def up_to_date(fmu_dir=DEFAULT_DIR):
    """True when both FMUs exist and were built from the current satmotor and glue sources."""
    from .fmu_build import GLUE

    want = satmotor.source_fingerprint(GLUE)
    return all(built_fingerprint(p, _SLAVES[p.name]) == want for p in paths(fmu_dir))


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

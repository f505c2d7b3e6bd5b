"""Where the FMUs are, whether they match the current sources, and building them.

The orchestration never imports the FMU code: it runs :mod:`orchestration.packaging.fmu_build` in a child
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
# variant -> subdirectory of the FMU directory.  python: the pythonfmu FMUs (the executable
# specification, the default); native: C, FMI 2.0; native-fmi3: C, FMI 3.0 (bit-identical results)
VARIANTS = {"python": "", "native": "native", "native-fmi3": "native-fmi3"}
DEFAULT_VARIANT = "python"


def paths(fmu_dir=DEFAULT_DIR, variant=DEFAULT_VARIANT):
    """(plant, controller) FMU paths of ``variant`` in ``fmu_dir``."""
    d = Path(fmu_dir) / VARIANTS[variant]
    return d / PLANT, d / CONTROLLER


def _built_from(path, member):
    try:
        with zipfile.ZipFile(path) as z:
            return z.read(member).decode().strip()
    except (OSError, KeyError, zipfile.BadZipFile):
        return None


def binary_folders(path):
    """The platform folders under ``binaries/`` of the FMU ``path`` (empty if it cannot be read)."""
    try:
        with zipfile.ZipFile(path) as z:
            return {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2}
    except (OSError, zipfile.BadZipFile):
        return set()


def up_to_date(fmu_dir=DEFAULT_DIR, all_platforms=False):
    """True when every FMU of every variant exists and was built from the current sources
    (:func:`orchestration.packaging.fmu_build.inputs_fingerprint`,
    :func:`orchestration.packaging.native.fmus.inputs_fingerprint`); with ``all_platforms``, when the native
    ones also hold the binaries of every platform (:data:`orchestration.packaging.native.fmus.ALL`)."""
    from orchestration.packaging.fmu_build import BUILD_INPUTS, inputs_fingerprint
    from orchestration.packaging.native import fmus as native_fmus

    for variant in VARIANTS:
        for p in paths(fmu_dir, variant):
            if variant == "python":
                ok = _built_from(p, BUILD_INPUTS) == inputs_fingerprint(p.stem)
            else:
                built = _built_from(p, "resources/" + native_fmus.BUILD_INPUTS)
                ok = built == native_fmus.inputs_fingerprint(p.stem)
                if ok and all_platforms:
                    version = next(v for v, d in native_fmus.DIRS.items() if d == VARIANTS[variant])
                    ok = set(native_fmus.ALL[version]) <= binary_folders(p)
            if not ok:
                return False
    from orchestration.packaging.native import clocked
    from orchestration.packaging.native import model_exchange as native_me

    return native_me.up_to_date(fmu_dir, all_platforms) and clocked.up_to_date(fmu_dir, all_platforms)


def build(fmu_dir=DEFAULT_DIR, quiet=False, all_platforms=False):
    """Build the FMUs of every variant into ``fmu_dir``, for this machine (with ``all_platforms``:
    for Windows and macOS too, cross-compiled with zig); raises CalledProcessError when the build
    fails.  Returns the pythonfmu FMUs' paths."""
    cmd = [sys.executable, "-m", "orchestration.packaging.fmu_build", "--out", str(fmu_dir)]
    subprocess.run(cmd + (["--all-platforms"] if all_platforms else []), check=True,
                   stdout=subprocess.DEVNULL if quiet else None)
    return paths(fmu_dir)


def ensure(fmu_dir=DEFAULT_DIR, quiet=False, variant=DEFAULT_VARIANT):
    """The FMU paths of ``variant``, every variant built first when missing or stale."""
    if not up_to_date(fmu_dir):
        build(fmu_dir, quiet)
    return paths(fmu_dir, variant)

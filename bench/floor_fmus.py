"""Two do-nothing pythonfmu FMUs with the variables of ours: the floor of the pythonfmu path.

``build(out_dir)`` writes ``FloorSaturatedInductionMotor.fmu`` and ``FloorBacksteppingController.fmu``
into ``out_dir`` (the benchmark passes a temporary directory: they are never shipped).  Each has
the same variables as the project's FMU of that name (names, value references, causalities, types:
registered from the same ``satmotor.interface`` tables in the same order; the build checks them
against the model description of a real build) but no physics and no glue: ``do_step``
returns True, ``get_real``/``get_integer``/``get_boolean`` return a list of zeros of the asked
length, ``set_real`` ignores its values.  What a co-simulation of these costs is what pythonfmu's
C++ wrapper, fmpy's ctypes loading and the master's loop cost per step before any code of ours
runs in the FMU.

The script of each FMU is generated with the variable table as a literal (it imports neither
``satmotor`` nor the glue) and built with pythonfmu's builder in a child process (the builder
imports the script).  Run as ``python bench/floor_fmus.py OUT_DIR``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# real FMU (orchestration.packaging.fmu_build.FMUS) -> floor FMU class name
FLOOR = {"SaturatedInductionMotor": "FloorSaturatedInductionMotor",
         "BacksteppingController": "FloorBacksteppingController"}

_TEMPLATE = '''"""Floor FMU: the variables of {real}, no physics (benchmark only, never shipped)."""

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String

VARIABLES = {variables!r}
_TYPES = {{"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}}


class {name}(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for var_name, causality, kind, start in VARIABLES:
            setattr(self, var_name, start)
            kw = {{"causality": getattr(Fmi2Causality, causality)}}
            if causality == "parameter":
                kw["variability"] = Fmi2Variability.fixed
            elif kind == "Real":
                kw["variability"] = Fmi2Variability.continuous
            else:
                kw["variability"] = Fmi2Variability.discrete
            if causality == "output":
                kw["initial"] = Fmi2Initial.exact
            self.register_variable(_TYPES[kind](var_name, **kw))

    def do_step(self, current_time, step_size):
        return True

    def get_real(self, vrs):
        return [0.0] * len(vrs)

    def get_integer(self, vrs):
        return [0] * len(vrs)

    def get_boolean(self, vrs):
        return [False] * len(vrs)

    def set_real(self, vrs, values):
        return None
'''


def script(real):
    """The source of the floor slave of the real FMU ``real`` (a key of :data:`FLOOR`)."""
    import satmotor.interface as itf
    from orchestration.packaging.fmu_build import FMUS

    tables = FMUS[real][1]  # the slave's VARIABLES: these tables joined in this order
    variables = tuple((v.name, v.causality, v.type, v.start) for t in tables for v in getattr(itf, t))
    return _TEMPLATE.format(real=real, name=FLOOR[real], variables=variables)


def _build_one(real, out_dir):
    """Build the floor FMU of ``real`` in this process (the builder imports the script)."""
    from pythonfmu.builder import FmuBuilder

    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / f"floor_{FLOOR[real].lower()}.py"
        src.write_text(script(real))
        return FmuBuilder.build_FMU(src, dest=Path(out_dir) / f"{FLOOR[real]}.fmu")


def interface(path):
    """``[(name, value reference, causality, type)]`` of the FMU at ``path``."""
    from fmpy import read_model_description

    md = read_model_description(str(path))
    return [(v.name, v.valueReference, v.causality, v.type) for v in md.modelVariables]


def build(out_dir, real_dir):
    """Build both floor FMUs into ``out_dir``, each in a child process; check that each has the
    interface of the real FMU of that name in ``real_dir``.  Returns (plant, controller) paths."""
    paths = []
    for real, floor in FLOOR.items():
        subprocess.run([sys.executable, str(Path(__file__).resolve()), str(out_dir), real], cwd=ROOT,
                       check=True, stdout=subprocess.DEVNULL)
        path = Path(out_dir) / f"{floor}.fmu"
        with zipfile.ZipFile(path) as z:  # a real build, not a leftover
            z.getinfo("modelDescription.xml")
        want, got = interface(Path(real_dir) / f"{real}.fmu"), interface(path)
        if want != got:
            diff = [(w, g) for w, g in zip(want, got) if w != g][:4]
            raise RuntimeError(f"{path}: its variables differ from {real}.fmu's: {diff} "
                               f"({len(got)} variables, {len(want)} in {real}.fmu)")
        paths.append(path)
    return tuple(paths)


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    _build_one(sys.argv[2], sys.argv[1])

"""Build the two FMI 2.0 co-simulation FMUs: ``python build_fmus.py [--out DIR]`` (default build/fmus/).

The build logic is importable as :mod:`orchestration.build.fmu_build` (also ``satmotor-cosim build``).
"""

from orchestration.build.documentation import documentation
from orchestration.build.fmu_build import build_all, build_one, main, make_reproducible
from orchestration.build.sources import FMUS

__all__ = ["FMUS", "build_all", "build_one", "documentation", "main", "make_reproducible"]

if __name__ == "__main__":
    main()

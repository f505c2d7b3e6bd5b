"""Build the FMUs: ``python build_fmus.py [--out DIR] [--all-platforms]`` (default build/fmus/, this machine).

The build logic is importable as :mod:`orchestration.build.fmu_build` (also ``satmotor-cosim build``).
"""

import sys

from orchestration.build.documentation import documentation
from orchestration.build.fmu_build import build_all, build_one, main, make_reproducible
from orchestration.build.sources import FMUS

__all__ = ["FMUS", "build_all", "build_one", "documentation", "main", "make_reproducible"]

if __name__ == "__main__":
    sys.exit(main())

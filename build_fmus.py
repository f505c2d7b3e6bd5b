"""Build the FMUs: ``python build_fmus.py [--out DIR] [--all-platforms]`` (default build/fmus/, this machine).

The build logic is importable as :mod:`orchestration.packaging.fmu_build` (also ``satmotor-cosim build``).
"""

import sys

from orchestration.packaging.documentation import documentation
from orchestration.packaging.fmu_build import build_all, build_one, main, make_reproducible
from orchestration.packaging.sources import FMUS

__all__ = ["FMUS", "build_all", "build_one", "documentation", "main", "make_reproducible"]

if __name__ == "__main__":
    sys.exit(main())

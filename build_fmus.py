"""Build the FMUs: ``python build_fmus.py [--out DIR] [--all-platforms]`` (default build/fmus/, this machine).

The build logic is importable as :mod:`orchestration.fmu_build` (also ``satmotor-cosim build``).
"""

import sys

from orchestration.fmu_build import FMUS, build_all, build_one, documentation, main, make_reproducible

__all__ = ["FMUS", "build_all", "build_one", "documentation", "main", "make_reproducible"]

if __name__ == "__main__":
    sys.exit(main())

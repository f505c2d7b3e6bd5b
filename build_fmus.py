"""Build the two FMI 2.0 co-simulation FMUs: ``python build_fmus.py [--out DIR]`` (default build/fmus/).

The build logic is importable as :mod:`orchestration.fmu_build` (also ``satmotor-cosim build``).
"""

from orchestration.fmu_build import FMUS, build_all, build_one, documentation, main, make_reproducible

__all__ = ["FMUS", "build_all", "build_one", "documentation", "main", "make_reproducible"]

if __name__ == "__main__":
    main()

"""The FMU sources (pythonfmu slave scripts and their shared glue), installed as
``satmotor_fmu_sources`` for the build (:mod:`orchestration.packaging.fmu_build`); nothing to import."""

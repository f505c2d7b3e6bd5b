"""Every FMU and generated artefact, from the interface tables of :mod:`satmotor.interface`.

* :mod:`~orchestration.build.fmus` -- where the FMUs are, whether they are current, building them.
* :mod:`~orchestration.build.sources` -- where the FMU sources are; what each pythonfmu FMU is made of.
* :mod:`~orchestration.build.fmu_build` -- the pythonfmu FMUs (``build_fmus.py``).
* :mod:`~orchestration.build.native.fmus`, :mod:`~orchestration.build.native.compiler` -- the native C
  FMUs (FMI 2.0 and 3.0; compiled with gcc or zig, cross builds) and their packing.
* :mod:`~orchestration.build.fmu_model_description`, :mod:`~orchestration.build.native.model_description`,
  :mod:`~orchestration.build.native.tables`, :mod:`~orchestration.build.documentation` -- model
  descriptions, the C variable tables and the FMUs' documentation pages.
* :mod:`~orchestration.build.signals_fmu` -- ScenarioSignals.fmu, a scenario's profiles for SSP engines;
  :mod:`~orchestration.build.ssd` -- the SSP system description of a scenario.
* :mod:`~orchestration.build.reference_results` -- the reference results shipped for the FMUs.
* :mod:`~orchestration.build.variable_tables` -- the variable tables of the documentation.
"""

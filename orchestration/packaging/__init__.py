"""Every FMU and generated artefact, from the interface tables of :mod:`satmotor.interface`.

* :mod:`~orchestration.packaging.fmus` -- where the FMUs are, whether they are current, building them.
* :mod:`~orchestration.packaging.sources` -- where the FMU sources are; what each pythonfmu FMU is made of.
* :mod:`~orchestration.packaging.fmu_build` -- the pythonfmu FMUs (``build_fmus.py``).
* :mod:`~orchestration.packaging.native.fmus`, :mod:`~orchestration.packaging.native.compiler` -- the native C
  FMUs (FMI 2.0 and 3.0; compiled with gcc or zig, cross builds) and their packing.
* :mod:`~orchestration.packaging.fmu_model_description`,
  :mod:`~orchestration.packaging.native.model_description`, :mod:`~orchestration.packaging.native.tables`,
  :mod:`~orchestration.packaging.documentation` -- model descriptions, the C variable tables and the
  FMUs' documentation pages.
* :mod:`~orchestration.packaging.signals_fmu` -- ScenarioSignals.fmu, a scenario's profiles for SSP engines;
  :mod:`~orchestration.packaging.ssd` -- the SSP system description of a scenario.
* :mod:`~orchestration.packaging.reference_results` -- the reference results shipped for the FMUs.
* :mod:`~orchestration.packaging.variable_tables` -- the variable tables of the documentation.
"""

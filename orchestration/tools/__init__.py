"""Tools beside the runs.

* :mod:`~orchestration.tools.ssp` -- ``export-ssp``: a scenario as an SSP 1.0 package.
* :mod:`~orchestration.tools.fit_curve` -- ``fit-curve``: a magnetizing curve from a no-load test
  (its figure: :mod:`~orchestration.tools.fit_curve_figure`).
"""

"""Shared fixtures: one instance of every magnetizing-curve family; the FMUs, built once per run."""

import pytest

from satmotor.machine.magnetics import ArctanCurve, ExponentialCurve, LinearCurve, PolynomialCurve
from satmotor.machine.table_curve import TableCurve


def no_load_table():
    """A no-load test as a user would measure it: points of a saturating curve
    that is not one of our families (a Froelich-type rational curve), unevenly spaced."""
    i = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.5, 9.0, 11.0, 14.0, 18.0)
    psi = tuple(0.012 * x + 0.945 * x / (3.0 + x) for x in i)
    return i, psi


CURVES = {
    "arctan": ArctanCurve(),
    "exponential": ExponentialCurve(),
    "polynomial": PolynomialCurve(),
    "table": TableCurve(*no_load_table()),
    "linear": LinearCurve(0.1722),
}
SATURATING = [k for k in CURVES if k != "linear"]


@pytest.fixture(params=list(CURVES))
def curve(request):
    return CURVES[request.param]


@pytest.fixture(params=SATURATING)
def saturating_curve(request):
    return CURVES[request.param]


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory):
    """Directory holding both pythonfmu FMUs, built once per test run (build_fmus.py)."""
    from orchestration.build import fmus

    d = tmp_path_factory.mktemp("fmus")
    fmus.build(d, quiet=True)
    return d

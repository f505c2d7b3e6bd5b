"""One variant of a sweep loaded alone (``load_variant``, what a batch child runs) is the variant the
full expansion gives (``load_sweep``), and its values are the draws written out here from the
documented rule (one ``numpy.random.default_rng(seed)``, ``samples`` values per parameter in the
file's order; a grid varies the last parameter fastest), whatever the order the variants are loaded
in; the design kept between loads follows the file's text."""

import itertools

import numpy as np
import pytest
import yaml

from orchestration.scenario.variants import load_sweep, load_variant

BASE = {"name": "s", "stop_time": 0.2, "mismatch": True, "plant": {"R_r": 1.6},
        "profiles": {"psi_ref": {"type": "constant", "value": 0.9},
                     "omega_ref": {"type": "step", "time": 0.05, "value": 20.0}}}


def _write(path, sweep):
    path.write_text(yaml.safe_dump({**BASE, "sweep": sweep}, sort_keys=False))
    return path


def test_a_monte_carlo_variant_alone_is_the_full_expansion_and_the_reference_draws(tmp_path):
    n, seed = 300, 11
    f = _write(tmp_path / "mc.yaml", {"samples": n, "seed": seed, "parameters": {
        "plant.R_r": {"tolerance": 0.2}, "plant.J": {"normal": [0.0131, 0.001]},
        "controller.c1": {"uniform": [150.0, 250.0]}}})
    rng = np.random.default_rng(seed)  # the reference: the documented draws, in the file's order
    R_r = rng.uniform(1.6 * 0.8, 1.6 * 1.2, n)
    J = rng.normal(0.0131, 0.001, n)
    c1 = rng.uniform(150.0, 250.0, n)
    _, sweep, full = load_sweep(f)
    assert len(full) == n
    for i in [n - 1, 0, 157, 3, n - 2] + list(range(0, n, 7)):  # any order: the kept design is the same
        sc = load_variant(f, i)
        assert sc == full[i][1]
        assert (sc.plant["R_r"], sc.plant["J"], sc.controller["c1"]) == (R_r[i], J[i], c1[i])
        assert sc.name == f"s-{i:03d}" and sc.record.level == "metrics"


def test_a_grid_variant_alone_is_the_full_expansion(tmp_path):
    J, d1 = [0.01, 0.02, 0.03], [50.0, 100.0, 150.0, 200.0]
    f = _write(tmp_path / "grid.yaml", {"parameters": {"plant.J": J, "controller.d1": d1}})
    _, _, full = load_sweep(f)
    reference = list(itertools.product(J, d1))  # the last parameter fastest
    for i in reversed(range(len(reference))):
        sc = load_variant(f, i)
        assert sc == full[i][1] and (sc.plant["J"], sc.controller["d1"]) == reference[i]


def test_an_edited_file_gives_its_new_draws(tmp_path):
    sweep = {"samples": 20, "seed": 1, "parameters": {"plant.R_r": {"uniform": [1.0, 2.0]}}}
    f = _write(tmp_path / "edit.yaml", sweep)
    first = load_variant(f, 5).plant["R_r"]
    assert first == np.random.default_rng(1).uniform(1.0, 2.0, 20)[5]
    _write(f, {**sweep, "seed": 2})
    assert load_variant(f, 5).plant["R_r"] == np.random.default_rng(2).uniform(1.0, 2.0, 20)[5]
    _write(f, {**sweep, "samples": 5})
    with pytest.raises(Exception, match="no variant 5: the file has 5"):
        load_variant(f, 5)
    f.write_text("name: [unclosed\n")
    with pytest.raises(Exception, match="invalid YAML"):
        load_variant(f, 0)


def test_a_sobol_variant_alone_is_the_full_expansion(tmp_path):
    pytest.importorskip("SALib")
    f = _write(tmp_path / "sobol.yaml", {"analysis": "sobol", "samples": 8, "seed": 3, "parameters": {
        "plant.R_r": {"tolerance": 0.2}, "plant.J": {"uniform": [0.01, 0.02]}}})
    _, sweep, full = load_sweep(f)
    assert len(full) == 8 * 4
    for i in (31, 0, 17, 5):
        assert load_variant(f, i) == full[i][1]

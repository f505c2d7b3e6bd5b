"""``pip install .`` gives a working ``satmotor-cosim`` outside a checkout: the package carries the
FMU sources and the build logic, and declares every third-party package the commands import."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[1]
# import name -> distribution name, where they differ
DISTRIBUTION = {"yaml": "pyyaml", "fmpy": "fmpy", "pythonfmu": "pythonfmu", "distributed": "dask",
                "fmu_manipulation_toolbox": "fmu-manipulation-toolbox", "SALib": "salib"}
# import name -> extra: batch --scheduler (dask), check (its second checker), run --engine libcosim, fit-curve
OPTIONAL = {"distributed": "dask", "dask": "dask", "fmu_manipulation_toolbox": "check",
            "libcosimpy": "libcosim", "scipy": "fit", "SALib": "study"}


def _name(requirement):
    return re.match(r"[A-Za-z0-9_.-]+", requirement).group(0).lower()


def _third_party_imports(package):
    names = set()
    for f in (ROOT / package).rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Import):
                names |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    ours = ("satmotor", "orchestration", "satmotor_fmu_glue", "satmotor_fmu_sources")
    return {n for n in names if n not in sys.stdlib_module_names and n not in ours}


def test_every_package_the_commands_import_is_a_dependency():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    required = {_name(d) for d in meta["dependencies"]}
    extras = {extra: {_name(d) for d in deps} for extra, deps in meta["optional-dependencies"].items()}
    for package in ("satmotor", "orchestration"):
        for name in _third_party_imports(package):
            dist = DISTRIBUTION.get(name, name)
            wanted = extras[OPTIONAL[name]] if name in OPTIONAL else required
            assert dist in wanted, f"{package} imports {name}"
    assert _third_party_imports("satmotor") == {"numpy"}
    # what one command needs is its extra, not a dependency of every install; `make` installs them all
    assert not required & {"fmu-manipulation-toolbox", "libcosimpy", "scipy", "ziglang", "dask", "salib"}
    dev = next(d for d in meta["optional-dependencies"]["dev"] if d.startswith("satmotor["))
    extras_of_dev = set(dev.split("[")[1].rstrip("]").split(","))
    assert extras_of_dev == {"check", "libcosim", "ecos", "fit", "dask", "native", "study"}


@pytest.mark.parametrize("args,module,extra,code", [
    (["fit-curve", "noload.csv", "--R-s", "1", "--l-s", "0.01"], "scipy", "fit", 1),
    (["check", "x.fmu"], "fmu_manipulation_toolbox", "check", 2),
    (["run", "s.yaml", "--engine", "libcosim"], "libcosimpy", "libcosim", 1),
])
def test_a_command_whose_extra_is_missing_says_which_pip_install_in_one_line(args, module, extra, code,
                                                                          monkeypatch, capsys, tmp_path):
    from orchestration.cli import commands as cli

    monkeypatch.chdir(tmp_path)
    monkeypatch.setitem(sys.modules, module, None)  # not importable, as if not installed
    assert cli.main(args) == code
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.endswith(f'pip install "satmotor[{extra}]"\n'), err
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.slow
def test_installed_package_runs_build_validate_run_and_batch_outside_a_checkout(tmp_path):
    site = tmp_path / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site),
                        str(ROOT)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    work = tmp_path / "work"  # no checkout here: only a scenario file
    work.mkdir()
    (work / "s.yaml").write_text("name: s\nstop_time: 0.02\nprofiles:\n"
                                 "  psi_ref: {type: constant, value: 0.9}\n")
    env = {**os.environ, "PYTHONPATH": str(site)}

    def cli(*args):
        return subprocess.run([sys.executable, str(site / "bin" / "satmotor-cosim"), *args], cwd=work,
                              env=env, capture_output=True, text=True, timeout=600)

    where = subprocess.run([sys.executable, "-c", "import orchestration, satmotor_fmu_sources as s; "
                            "print(orchestration.__file__, s.__file__)"], cwd=work, env=env,
                           capture_output=True, text=True)
    assert where.stdout.count(str(site)) == 2, where  # the installed copy, not the checkout
    assert cli("validate", "s.yaml").returncode == 0
    r = cli("run", "s.yaml", "--out", "res")
    assert r.returncode == 0, r.stdout + r.stderr
    assert (work / "build" / "fmus" / "SaturatedInductionMotor.fmu").exists()
    assert (work / "res" / "s" / "metrics.json").exists()
    r = cli("batch", ".", "--out", "res_batch", "--jobs", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    assert (work / "res_batch" / "summary.csv").exists()
    # check finds the reference results in the installed package (no --reference, no checkout)
    r = cli("check", "build/fmus/BacksteppingController.fmu")
    assert re.search(r"^PASS .* reference: 21 outputs over \d+ rows", r.stdout, re.M), r.stdout + r.stderr


def test_a_change_to_any_build_input_makes_the_fmus_stale(fmu_dir, tmp_path, monkeypatch):
    import shutil
    import zipfile

    from orchestration.packaging import fmu_build, fmus

    assert fmus.up_to_date(fmu_dir)
    copy = tmp_path / "fmus"
    shutil.copytree(fmu_dir, copy)
    assert fmus.up_to_date(copy)
    # the slave script changed since the build (one comment line): the recorded inputs differ
    script, *rest = fmu_build.FMUS["SaturatedInductionMotor"]
    edited = tmp_path / script.name
    edited.write_text(script.read_text() + "# edited\n")
    monkeypatch.setitem(fmu_build.FMUS, "SaturatedInductionMotor", (edited, *rest))
    assert not fmus.up_to_date(copy)
    monkeypatch.undo()
    plain = tmp_path / "old.fmu"  # an FMU built before the record existed
    with zipfile.ZipFile(copy / fmus.PLANT) as src, zipfile.ZipFile(plain, "w") as dst:
        for n in src.namelist():
            if n != fmu_build.BUILD_INPUTS:
                dst.writestr(n, src.read(n))
    shutil.move(plain, copy / fmus.PLANT)
    assert not fmus.up_to_date(copy)

"""Source-code FMUs: every native FMU (plant, controller, ScenarioSignals; FMI 2.0 and 3.0) carries its C
sources under sources/ with what a tool needs to build them alone
(orchestration/packaging/native/source_fmu.py):
the FMI 2.0 <SourceFiles> list, the FMI 3.0 sources/buildDescription.xml (validated against the
standard's schema by fmpy), the generated headers and fg_identity.h.

Each FMU is unpacked, its binaries/ deleted, and a binary built from sources/ alone, with a plain
`gcc -shared -fPIC <listed files> -lm` (no -D, no flags of ours) and, for FMI 2.0 and 3.0, with fmpy's
build_platform_binary (CMake, from the model description's or build description's file list). Both are
run with fmpy next to the shipped binary: the outputs must be the same bit for bit (same source, gcc on
x86_64 with SSE2 arithmetic and no FMA at any optimization level, the same libm)."""

import shutil
import subprocess
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from orchestration.packaging import signals_fmu
from orchestration.scenario.load import load_scenario

ROOT = Path(__file__).resolve().parents[1]
INPUTS = {  # constant inputs: a rotating machine's terminal values (as tests/test_native_windows.py)
    "SaturatedInductionMotor": {"v_s_alpha": 150.0, "v_s_beta": -40.0, "T_load": 5.0},
    "BacksteppingController": {"psi_r_alpha": 0.9, "i_s_alpha": 5.0, "psi_ref": 0.95, "omega_ref": 50.0},
    "ScenarioSignals": {},
}
FMUS = [(d, n) for d in ("native", "native-fmi3")
        for n in ("SaturatedInductionMotor", "BacksteppingController")]


def _gcc():
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed (as root on Debian, `make system-packages` installs it)")


@pytest.fixture(scope="module")
def signals(tmp_path_factory):
    d = tmp_path_factory.mktemp("signals")
    sc = load_scenario(ROOT / "scenarios" / "ramp_rated_load.yaml")
    return {v: signals_fmu.build(sc, d / v, fmi_version=v) for v in ("2.0", "3.0")}


def _fmu(fmu_dir, signals, where, name):
    return signals[where] if name == "ScenarioSignals" else fmu_dir / where / f"{name}.fmu"


def _cases():
    return [*FMUS, ("2.0", "ScenarioSignals"), ("3.0", "ScenarioSignals")]


def _unpack(fmu, out):
    with zipfile.ZipFile(fmu) as z:
        z.extractall(out)
    return out


def _listed(unzip):
    md = read_model_description(str(unzip))
    assert len(md.buildConfigurations) == 1
    (files,) = [s.sourceFiles for s in md.buildConfigurations[0].sourceFileSets]
    return md, files


def _binary(unzip, md):
    ident = md.coSimulation.modelIdentifier
    folder = "linux64" if md.fmiVersion == "2.0" else "x86_64-linux"
    return unzip / "binaries" / folder / f"{ident}.so"


def _run(unzip, name):
    md = read_model_description(str(unzip))
    outs = [v.name for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    stop, h = (1.5, 1e-3) if name == "ScenarioSignals" else (0.05, 1e-4)  # the profiles move after 0.2 s
    res = simulate_fmu(str(unzip), start_time=0.0, stop_time=stop, output_interval=h,
                       start_values=INPUTS[name], output=outs)
    return res, outs


def _same(a, b, outs):
    assert len(a) == len(b) in (501, 1501)
    for n in outs:
        assert np.array_equal(a[n], b[n]), n
    assert max(np.ptp(a[n]) for n in outs) > 0  # something moved


@pytest.mark.parametrize("where, name", _cases())
def test_the_sources_are_listed_and_complete(fmu_dir, signals, where, name):
    with zipfile.ZipFile(_fmu(fmu_dir, signals, where, name)) as z:
        names = z.namelist()
        c_files = sorted(n[len("sources/"):] for n in names if n.startswith("sources/") and n.endswith(".c"))
        assert "sources/fg_identity.h" in names and "sources/BUILD.txt" in names
        for generated in ("sm_vars.h", "sm_vars.c") if name != "ScenarioSignals" else ():
            assert f"sources/{generated}" in names
        if name != "ScenarioSignals":
            assert "sources/sm_params.h" in names
        fmi3 = "fmiVersion=\"3.0\"" in z.read("modelDescription.xml").decode()
        assert ("sources/buildDescription.xml" in names) == fmi3
    md = read_model_description(str(_fmu(fmu_dir, signals, where, name)))  # validates the build description
    (listed,) = [s.sourceFiles for s in md.buildConfigurations[0].sourceFileSets]
    assert sorted(listed) == c_files and len(c_files) >= 4
    assert md.buildConfigurations[0].modelIdentifier == md.coSimulation.modelIdentifier


@pytest.mark.parametrize("where, name", _cases())
def test_gcc_builds_a_binary_from_the_sources_alone_that_runs_bit_for_bit(fmu_dir, signals, where, name,
                                                                          tmp_path):
    _gcc()
    fmu = _fmu(fmu_dir, signals, where, name)
    shipped = _unpack(fmu, tmp_path / "shipped")
    built = _unpack(fmu, tmp_path / "built")
    shutil.rmtree(built / "binaries")
    md, files = _listed(built)
    target = _binary(built, md)
    target.parent.mkdir(parents=True)
    r = subprocess.run(["gcc", "-shared", "-fPIC", *files, "-o", str(target), "-lm"], cwd=built / "sources",
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    a, outs = _run(shipped, name)
    b, _ = _run(built, name)
    _same(a, b, outs)


@pytest.mark.parametrize("where, name", FMUS)
def test_fmpy_build_platform_binary_builds_it_too(fmu_dir, where, name, tmp_path):
    _gcc()
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed (fmpy's build_platform_binary runs it)")
    from fmpy.build import build_platform_binary

    fmu = fmu_dir / where / f"{name}.fmu"
    shipped = _unpack(fmu, tmp_path / "shipped")
    built = _unpack(fmu, tmp_path / "built")
    shutil.rmtree(built / "binaries")
    (tmp_path / "cmake").mkdir()
    build_platform_binary(built, build_dir=tmp_path / "cmake")
    md = read_model_description(str(built))
    assert _binary(built, md).is_file()
    a, outs = _run(shipped, name)
    b, _ = _run(built, name)
    _same(a, b, outs)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["SaturatedInductionMotor", "BacksteppingController"])
def test_the_sources_alone_build_for_a_platform_we_do_not_ship(fmu_dir, name, tmp_path):
    """An ARM Linux box: zig cc for aarch64-linux-gnu builds the FMI 3.0 FMU's listed sources with the
    build description's options into an aarch64 ELF (compiled only: no aarch64 machine or emulator here)."""
    import sys

    from orchestration.packaging.native import compiler as native_build

    if not native_build.zig_available():
        pytest.skip("zig is not installed (pip install ziglang, in the dev extra)")
    unzip = _unpack(fmu_dir / "native-fmi3" / f"{name}.fmu", tmp_path / "fmu")
    _, files = _listed(unzip)
    fileset = ET.parse(unzip / "sources" / "buildDescription.xml").find(".//SourceFileSet")
    options = fileset.get("compilerOptions")
    assert options == "-ffp-contract=off"
    out = tmp_path / f"{name}.so"
    zig = [sys.executable, "-m", "ziglang", "cc", "-target", "aarch64-linux-gnu.2.17"]
    r = subprocess.run([*zig, "-std=c99", "-O2", "-shared", "-fPIC", *options.split(), *files, "-o", str(out),
                        "-lm"],
                       cwd=unzip / "sources", capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    head = out.read_bytes()[:20]
    assert head[:4] == b"\x7fELF" and int.from_bytes(head[18:20], "little") == 183  # EM_AARCH64

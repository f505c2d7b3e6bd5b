"""The Windows binaries of the native FMUs (binaries/win64 of FMI 2.0, binaries/x86_64-windows of FMI 3.0),
really run: tests/native_c_host.c cross-compiled with zig for x86_64-windows-gnu, run under wine, against
the Linux binary of the same FMU (both from the session's all-platforms build, conftest.fmu_dir_all_platforms)
in the same host compiled with gcc, with the same parameters and constant inputs, and on the reference
inputs of reference/ (every output at every communication point, bit for bit). Skipped (with the reason)
without wine or zig; `make system-packages` (scripts/system_packages.sh, run by .ci/run) installs wine.

Tolerance: both binaries come from the same C source, compiled by zig (clang) at -O2 with
-ffp-contract=off, so the arithmetic is the same instruction for instruction; what differs is the libm:
glibc's on Linux; under Windows atan2, expm1 and pow from the UCRT (wine's ucrtbase here, not
Microsoft's) and sin, cos, exp and log from mingw-w64, linked into the DLL (atan and atan2 of the
per-step code are the project's own since 2026-12-02: satmotor/machine/atan.py).
On 200 000 random arguments the two sides
differed by one ulp (never more) for 4 % (atan), 10 % (exp), 23 % (atan2), under 0.1 % (expm1, pow) of
them. So the plant runs bit-identical for its first 60 steps, then drifts by a few ulps carried by the
motor's dynamics: after 300 steps of 100 us we saw 2.2e-14 of an output's size at most; the controller,
with constant inputs, stayed bit-identical. Since the arctan curve computes its own atan (sm_atan.c,
no libm call), both FMUs of both FMI versions came out bit-identical over the 300 steps (2026-11-26).
The test allows 1e-12 of each output's size (floor 1): room for another libm, and far below what a
wrong build (a struct layout, a calling convention, a parameter not taken) gives.

Also here, as it uses the same build: the default build is for this machine only, and `build
--all-platforms` (`make dist`) adds the Windows and macOS binaries."""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest
from fmpy import read_model_description

from orchestration.packaging import fmus
from orchestration.packaging.native import compiler as native_build

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
HOST_C = ROOT / "tests" / "native_c_host.c"
STEPS, H = 300, 1e-4
REL_TOL = 1e-12
# constant inputs as tests/test_native_fmus.py uses them: a rotating machine's terminal values
INPUTS = {
    "SaturatedInductionMotor": {"v_s_alpha": 150.0, "v_s_beta": -40.0, "T_load": 5.0},
    "BacksteppingController": {"psi_r_alpha": 0.9, "i_s_alpha": 5.0, "psi_ref": 0.95, "omega_ref": 50.0},
}
CASES = [(v, i) for v in ("native", "native-fmi3") for i in (0, 1)]


def _wine():
    """The wine launcher (Debian's `wine` runs wine64 when wine32 is absent; WineHQ ships `wine64`)."""
    return shutil.which("wine64") or shutil.which("wine")


@dataclass(frozen=True)
class Hosts:
    linux: Path
    windows: Path
    wine: str
    wine_env: dict


@pytest.fixture(scope="module")
def hosts(tmp_path_factory):
    """The C host for Linux (gcc) and for Windows (zig), and a throw-away wine prefix (removed after the
    module: a wine 8 prefix is about 700 MB)."""
    wine = _wine()
    if wine is None:
        pytest.skip("wine is not installed (as root on Debian, `make system-packages` installs it)")
    if not native_build.zig_available():
        pytest.skip("zig is not installed (pip install ziglang, in the dev extra)")
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed (as root on Debian, `make system-packages` installs it)")
    d = tmp_path_factory.mktemp("hosts")
    inc = native_build.fmi_headers_dir()
    flags = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", f"-I{inc}"]
    subprocess.run(["gcc", *flags, str(HOST_C), "-o", str(d / "host"), "-ldl"], check=True)
    # clang warns on the () prototypes of fmpy's fmi3FunctionTypes.h (as in native_build).  -O2 as the
    # FMUs' DLLs are built: zig then links the MinGW runtime it compiled for them; without -O it compiles
    # a second one, in debug mode with the UBSan runtime (minutes on a fresh machine)
    zig = [sys.executable, "-m", "ziglang", "cc", "-target", "x86_64-windows-gnu"]
    r = subprocess.run([*zig, *flags, "-O2", "-Wno-strict-prototypes", "-ffp-contract=off", str(HOST_C), "-o",
                        str(d / "host.exe")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    prefix = tempfile.mkdtemp(prefix="wineprefix-")
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": os.environ.get("HOME", prefix),
           "WINEPREFIX": prefix, "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    quiet = {"env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "timeout": 120}
    subprocess.run([wine, "wineboot", "-i"], **quiet)  # the prefix, once (about 6 s)
    server = shutil.which("wineserver")
    if server is not None:  # then one server for the module (it detaches), not one per run
        subprocess.run([server, "-p"], **quiet)
    yield Hosts(d / "host", d / "host.exe", wine, env)
    if server is not None:
        subprocess.run([server, "-k"], **quiet)
    shutil.rmtree(prefix, ignore_errors=True)


def _windows_path(p: Path) -> str:
    """wine maps the Unix root to drive Z:."""
    return "Z:" + str(p).replace("/", "\\")


@dataclass(frozen=True)
class Unpacked:
    dir: Path
    token: str
    identifier: str
    fmi3: bool
    vr: dict

    def binary(self, windows: bool) -> Path:
        if self.fmi3:
            return self.dir / "binaries" / ("x86_64-windows" if windows else "x86_64-linux") / (
                self.identifier + (".dll" if windows else ".so"))
        return self.dir / "binaries" / ("win64" if windows else "linux64") / (
            self.identifier + (".dll" if windows else ".so"))

    def resources(self, windows: bool) -> str:
        d = self.dir / "resources"
        if self.fmi3:  # a directory path, with its trailing separator
            return _windows_path(d) + "\\" if windows else str(d) + "/"
        return "file:///" + _windows_path(d).replace("\\", "/") if windows else d.as_uri()


def _unpack(path: Path, into: Path) -> Unpacked:
    md = read_model_description(str(path))
    with zipfile.ZipFile(path) as z:
        z.extractall(into)
    return Unpacked(into, md.guid, md.coSimulation.modelIdentifier, md.fmiVersion.startswith("3"),
                    {v.name: v.valueReference for v in md.modelVariables})


def _outputs(path: Path) -> list[str]:
    md = read_model_description(str(path))
    return [v.name for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]


def _run(hosts: Hosts, fmu: Unpacked, windows: bool, sets: dict, outs: list[str]):
    """The host for ``windows`` or Linux: STEPS steps of H with the Real values ``sets``, then ``outs``."""
    lib = _windows_path(fmu.binary(True)) if windows else str(fmu.binary(False))
    args = [lib, fmu.token, fmu.resources(windows), str(STEPS), repr(H),
            *(f"{fmu.vr[n]}={v!r}" for n, v in sets.items()), "--", *(str(fmu.vr[n]) for n in outs)]
    if windows:
        cmd, env = [hosts.wine, str(hosts.windows), *args], hosts.wine_env
    else:
        cmd, env = [str(hosts.linux), *args], {}
    return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=120)


def _values(r) -> list[float]:
    assert r.returncode == 0, (r.returncode, r.stderr)
    return [float(x) for x in r.stdout.split()]


@pytest.mark.parametrize("variant,which", CASES, ids=[f"{v}-{'plant' if i == 0 else 'controller'}"
                                                      for v, i in CASES])
def test_the_windows_binary_under_wine_gives_the_linux_numbers(variant, which, hosts, fmu_dir_all_platforms,
                                                               tmp_path):
    path = fmus.paths(fmu_dir_all_platforms, variant)[which]
    fmu = _unpack(path, tmp_path / "fmu")
    outs = _outputs(path)
    sets = INPUTS[fmu.identifier]
    linux = _values(_run(hosts, fmu, False, sets, outs))
    windows = _values(_run(hosts, fmu, True, sets, outs))
    assert len(linux) == len(windows) == len(outs)
    worst = {n: abs(a - b) / max(abs(b), 1.0) for n, a, b in zip(outs, windows, linux)}
    print(f"{path.parent.name}/{path.name}: worst relative difference after {STEPS} steps "
          f"{max(worst.values()):.3g} ({max(worst, key=worst.get)}); bit-identical outputs "
          f"{sum(a == b for a, b in zip(windows, linux))}/{len(outs)}")
    assert all(w <= REL_TOL for w in worst.values()), worst
    assert any(abs(b) > 1e-3 for b in linux)  # the run went somewhere: not all outputs at rest


@pytest.mark.parametrize("variant", ("native", "native-fmi3"))
def test_a_bad_parameter_is_refused_under_windows_with_the_linux_message(variant, hosts,
                                                                         fmu_dir_all_platforms, tmp_path):
    """J = 0: initialization fails (the host exits 5, not a crash), the FMU logs the reason through
    the host's logger with status error (3), the same line as on Linux."""
    path = fmus.paths(fmu_dir_all_platforms, variant)[0]
    fmu = _unpack(path, tmp_path / "fmu")
    runs = {w: _run(hosts, fmu, w, {"J": 0.0}, ["omega_m"]) for w in (False, True)}
    for windows, r in runs.items():
        assert r.returncode == 5, (windows, r.returncode, r.stderr)
        assert r.stdout.strip() == ""
    lines = {w: [line for line in r.stderr.splitlines() if "J = " in line] for w, r in runs.items()}
    assert lines[True] == lines[False] == ["[host] status 3: J = 0.0: must be a finite number > 0"], runs


PLATFORMS = {  # binaries/ folders: the default build (this machine) and build --all-platforms
    "native": ({"linux64"}, {"linux64", "win64", "darwin64"}),
    "native-fmi3": ({"x86_64-linux"}, {"x86_64-linux", "x86_64-windows", "x86_64-darwin", "aarch64-darwin"}),
}


def test_the_default_build_is_for_this_machine_only_and_all_platforms_adds_windows_and_macos(
        fmu_dir, fmu_dir_all_platforms, tmp_path):
    """The session's build (what `make demo`, `build` and `run` make) has the Linux binary only; `build
    --all-platforms` (`make dist`) has the Windows and macOS ones too, valid FMUs, the Linux binary
    linked against glibc 2.17 at most; `build --if-stale` sees which is which."""
    from fmpy.validation import validate_fmu

    for variant, (here, everywhere) in PLATFORMS.items():
        for mine, dist in zip(fmus.paths(fmu_dir, variant), fmus.paths(fmu_dir_all_platforms, variant)):
            assert fmus.binary_folders(mine) == here, mine
            assert fmus.binary_folders(dist) == everywhere, dist
            assert validate_fmu(str(dist)) == [], dist
    assert fmus.up_to_date(fmu_dir) and not fmus.up_to_date(fmu_dir, all_platforms=True)
    assert fmus.up_to_date(fmu_dir_all_platforms, all_platforms=True)
    if shutil.which("objdump"):
        with zipfile.ZipFile(fmus.paths(fmu_dir_all_platforms, "native")[0]) as z:
            (tmp_path / "plant.so").write_bytes(z.read("binaries/linux64/SaturatedInductionMotor.so"))
        out = subprocess.run(["objdump", "-T", str(tmp_path / "plant.so")], capture_output=True,
                             text=True).stdout
        versions = {tuple(map(int, v.split("."))) for v in re.findall(r"GLIBC_(\d+\.\d+)", out)}
        assert versions and max(versions) <= (2, 17), versions


REFERENCE = ROOT / "reference"


def _reference_table(fmu: Unpacked, name: str, into: Path) -> Path:
    """reference/<name>/<name>_in.csv as the host's inputs table (rows 0..N-1: row k set before the
    step from t_k; the last row is the inputs at the stop time, never stepped from)."""
    lines = (REFERENCE / name / f"{name}_in.csv").read_text().splitlines()
    header = lines[0].split(",")[1:]
    rows = [line.split(",")[1:] for line in lines[1:-1]]
    path = into / f"{name}_in.txt"
    path.write_text(" ".join([str(len(header)), *(str(fmu.vr[n]) for n in header)]) + "\n"
                    + "\n".join(" ".join(r) for r in rows) + "\n")
    return path


def _rows(r) -> list[tuple[float, ...]]:
    assert r.returncode == 0, (r.returncode, r.stderr)
    return [tuple(float(x) for x in line.split()) for line in r.stdout.splitlines()]


# the controller's law still calls sin and cos (sm_law.c), which the DLL takes from mingw-w64's static
# libm: 1 ulp from glibc's on about 3 % of arguments (measured 2026-12-02 on 80 000 of them, under and
# over pi): 23 of the 3001 rows differ from t = 0.2622 s (before the own atan2, 231 from t = 0.2032 s)
SIN_COS = pytest.mark.xfail(strict=True, reason="sin/cos of mingw-w64 differ from glibc's by 1 ulp on ~3 % "
                            "of arguments: 23 of 3001 controller rows differ (from t = 0.2622 s)")
REFERENCE_CASES = [pytest.param(v, i, marks=SIN_COS if i == 1 else (),
                                id=f"{v}-{'plant' if i == 0 else 'controller'}") for v, i in CASES]


@pytest.mark.parametrize("variant,which", REFERENCE_CASES)
def test_the_reference_inputs_under_wine_give_the_linux_rows_bit_for_bit(variant, which, hosts,
                                                                         fmu_dir_all_platforms, tmp_path):
    """The ramp (the controller's reference: pre-magnetization, the law, the speed ramp) and the
    direct-on-line start with the load step (the plant's) of reference/, every output at every
    communication point: the Windows binary under wine and the Linux one give the same bits when the
    per-step code calls no libm function whose last bit differs between glibc and the Windows
    runtime: its atan and atan2 are the project's own (satmotor/machine/atan.py); the plant's
    default path calls no other; the controller's law still calls sin and cos (:data:`SIN_COS`)."""
    path = fmus.paths(fmu_dir_all_platforms, variant)[which]
    fmu = _unpack(path, tmp_path / "fmu")
    outs = _outputs(path)
    table = _reference_table(fmu, fmu.identifier, tmp_path)
    options = (REFERENCE / fmu.identifier / "ReferenceOptions.txt").read_text()
    h = float(options.split("StepSize,")[1].split()[0])

    def run(windows):
        lib = _windows_path(fmu.binary(True)) if windows else str(fmu.binary(False))
        arg = "@" + (_windows_path(table) if windows else str(table))
        args = [lib, fmu.token, fmu.resources(windows), arg, repr(h), "--", *(str(fmu.vr[n]) for n in outs)]
        cmd = [hosts.wine, str(hosts.windows), *args] if windows else [str(hosts.linux), *args]
        env = hosts.wine_env if windows else {}
        return _rows(subprocess.run(cmd, capture_output=True, text=True, env=env,
                                    timeout=300))

    linux, windows = run(False), run(True)
    assert len(linux) == len(windows) == len(table.read_text().splitlines())  # t_0 .. t_N
    differ = [k for k, (a, b) in enumerate(zip(linux, windows)) if a != b]
    first = f", the first at t = {differ[0] * h:.4f} s" if differ else ""
    print(f"{path.parent.name}/{path.name}: {len(differ)} of {len(linux)} rows differ{first}")
    assert not differ, (len(differ), differ[:5])
    assert any(abs(v) > 1e-3 for v in linux[-1])  # the run went somewhere

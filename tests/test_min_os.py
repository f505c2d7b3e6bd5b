"""The oldest system each shipped binary declares it loads on, read from the binaries' own headers
(tests/binary_headers.py: struct only), and what README.md and docs/hosts.md say about it.

* macOS: both Mach-O binaries (x86_64 and arm64) carry LC_BUILD_VERSION with minos 11.0 (zig's default
  would be 15.0, which a Mac on macOS 11-14 need not load).
* Linux: the distributable binary (zig against glibc 2.17) needs no GLIBC_ symbol version above 2.17.
* Windows: the DLLs' PE header and their imports (the Universal C Runtime, api-ms-win-crt-*).

The fast tests compile a small C file through the build's own compile step (native_build.compile_binary,
the platform table the FMU builds use); the slow one reads every binary of the distributable FMUs
(conftest.fmu_dir_all_platforms, as tests/test_native_windows.py)."""

import re
import sys
import zipfile
from pathlib import Path

import pytest

from orchestration.packaging.native import compiler as native_build

sys.path.insert(0, str(Path(__file__).resolve().parent))
from binary_headers import elf_glibc_versions, macho_min_os, macho_slices, pe_min_os  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MACOS = {"darwin64": "x86_64", "aarch64-darwin": "arm64"}
GLIBC_MAX = (2, 17)
WINDOWS_PE = (6, 0)


def _need_zig():
    if not native_build.zig_available():
        pytest.skip("zig is not installed (pip install ziglang, in the dev extra)")


@pytest.mark.parametrize("platform", sorted(MACOS))
def test_the_macos_build_declares_macos_11(platform, tmp_path):
    _need_zig()
    (tmp_path / "m.c").write_text("#include <math.h>\n__attribute__((visibility(\"default\"))) double "
                                  "sm_f(double x) { return exp(x) + atan2(x, 1.0); }\n")
    out = tmp_path / "m.dylib"
    native_build.compile_binary(tmp_path, ["m.c"], "m", "{t}", native_build.PLATFORMS[platform], out)
    info = macho_min_os(out.read_bytes())
    assert info["cpu"] == MACOS[platform]
    assert info["platform"] == 1  # PLATFORM_MACOS
    assert info["minos"] == (11, 0, 0), info


def test_the_header_readers_read_what_they_should():
    """The readers against hand-made headers: a wrong offset would read another field."""
    import struct
    cmd = struct.pack("<IIIIII", 0x32, 24, 1, (12 << 16) | (3 << 8) | 1, 27 << 16, 0)
    macho = struct.pack("<IiiIIIII", 0xFEEDFACF, 0x0100000C, 0, 6, 2, len(cmd) + 16, 0, 0)
    macho += struct.pack("<II", 0x1B, 16) + bytes(8) + cmd  # an LC_UUID first, then the build version
    assert macho_min_os(macho) == {"cpu": "arm64", "platform": 1, "minos": (12, 3, 1), "sdk": (27, 0, 0)}
    with pytest.raises(ValueError):
        macho_min_os(b"\x7fELF" + bytes(60))


def test_the_universal_macho_holds_both_slices_aligned():
    """compiler.fat_macho of two hand-made thin headers, read back by the independent reader."""
    import struct
    thin = [struct.pack("<Iii", 0xFEEDFACF, cpu, 3) + bytes(n)
            for cpu, n in ((0x01000007, 100), (0x0100000C, 20000))]
    fat = native_build.fat_macho(thin)
    assert struct.unpack_from(">II", fat, 0) == (0xCAFEBABE, 2)
    slices = macho_slices(fat)
    assert [(cpu, align) for cpu, align, _ in slices] == [("x86_64", 14), ("arm64", 14)]
    assert [data for _, _, data in slices] == thin
    assert struct.unpack_from(">iiIII", fat, 8) == (0x01000007, 3, 16384, 112, 14)
    assert struct.unpack_from(">iiIII", fat, 28) == (0x0100000C, 3, 32768, 20012, 14)


def _binaries(fmu):
    with zipfile.ZipFile(fmu) as z:
        return {n: z.read(n) for n in z.namelist() if n.startswith("binaries/") and not n.endswith("/")}


@pytest.mark.slow
def test_every_shipped_binary_declares_its_minimum(fmu_dir_all_platforms):
    seen = {"macho": 0, "elf": 0, "pe": 0}
    for fmu in sorted((fmu_dir_all_platforms / d / f) for d in ("native", "native-fmi3")
                      for f in ("SaturatedInductionMotor.fmu", "BacksteppingController.fmu")):
        for name, data in _binaries(fmu).items():
            where = f"{fmu.parent.name}/{fmu.name}:{name}"
            if name.endswith(".dylib"):
                slices = macho_slices(data)
                cpus = [cpu for cpu, _, _ in slices]
                want = ["x86_64", "arm64"] if name.startswith("binaries/darwin64/") else \
                    [MACOS[name.split("/")[1].replace("x86_64-darwin", "darwin64")]]
                assert cpus == want, (where, cpus)  # FMI 2.0's darwin64: universal, as the Reference-FMUs
                for cpu, _, thin in slices:
                    info = macho_min_os(thin)
                    assert info["cpu"] == cpu and info["minos"] == (11, 0, 0), (where, info)
                    seen["macho"] += 1
            elif name.endswith(".so"):
                versions = elf_glibc_versions(data)
                assert versions and max(versions) <= GLIBC_MAX, (where, versions)
                seen["elf"] += 1
            elif name.endswith(".dll"):
                info = pe_min_os(data)
                assert info["os"] == WINDOWS_PE and info["subsystem"] == WINDOWS_PE, (where, info)
                assert any(i.startswith("api-ms-win-crt-") for i in info["imports"]), (where, info)
                seen["pe"] += 1
    # Mach-O slices: FMI 2.0's universal darwin64 (x86_64 and arm64) and FMI 3.0's two thin ones, per FMU
    assert seen == {"macho": 8, "elf": 4, "pe": 4}, seen


@pytest.mark.slow
def test_hosts_names_every_dll_the_windows_binaries_import(fmu_dir, fmu_dir_all_platforms):
    """docs/hosts.md names every DLL the shipped Windows binaries import (read from the binaries: the
    pythonfmu ones from its wheel, the native ones as zig builds them); the UCRT's api sets by their
    prefix."""
    hosts = (ROOT / "docs" / "hosts.md").read_text()
    fmus_ = [*sorted(fmu_dir.glob("*.fmu")), *sorted((fmu_dir_all_platforms / "native").glob("*.fmu")),
             *sorted((fmu_dir_all_platforms / "native-fmi3").glob("*.fmu"))]
    seen = set()
    for fmu in fmus_:
        for name, data in _binaries(fmu).items():
            if name.endswith(".dll"):
                imports = pe_min_os(data)["imports"]
                seen.update(imports)
                named = [i for i in imports if not i.startswith("api-ms-win-crt-")]
                missing = [i for i in named if f"`{i}`" not in hosts]
                assert not missing, (fmu.name, name, missing)
    expected = {"python3.dll", "MSVCP140.dll", "VCRUNTIME140.dll", "VCRUNTIME140_1.dll", "KERNEL32.dll"}
    assert expected <= seen, seen
    assert "`api-ms-win-crt-*`" in hosts


def test_readme_and_hosts_state_the_minimum_of_every_binary():
    readme = (ROOT / "README.md").read_text()
    hosts = (ROOT / "docs" / "hosts.md").read_text()
    for text in (readme, hosts):
        assert re.search(r"macOS 11\b", text)
        assert "glibc 2.17" in text
        assert "Windows 10" in text
    assert native_build.MACOS_MIN == "11.0"

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


def _hand_made_pe():
    """A PE32+ header (OS 6.0, subsystem 6.1) with one section holding an import directory: KERNEL32.dll,
    one function by name (hint 5) and one by ordinal 7."""
    import struct
    pe = bytearray(0x400)
    pe[:2] = b"MZ"
    struct.pack_into("<I", pe, 0x3C, 0x40)
    pe[0x40:0x44] = b"PE\0\0"
    coff, opt = 0x44, 0x44 + 20
    struct.pack_into("<HHIIIHH", pe, coff, 0x8664, 1, 0, 0, 0, 240, 0x2022)
    struct.pack_into("<H", pe, opt, 0x20B)
    struct.pack_into("<6H", pe, opt + 40, 6, 0, 0, 0, 6, 1)
    struct.pack_into("<II", pe, opt + 112 + 8, 0x1000, 40)  # the import directory
    struct.pack_into("<8sIIII", pe, opt + 240, b".idata", 0x200, 0x1000, 0x200, 0x200)
    raw = 0x200 - 0x1000  # file offset of an RVA in the section
    struct.pack_into("<5I", pe, raw + 0x1000, 0x1040, 0, 0, 0x1080, 0x1060)  # then a zero descriptor
    struct.pack_into("<QQ", pe, raw + 0x1040, 0x10A0, (1 << 63) | 7)
    pe[raw + 0x1080:raw + 0x108D] = b"KERNEL32.dll\0"
    struct.pack_into("<H", pe, raw + 0x10A0, 5)
    pe[raw + 0x10A2:raw + 0x10BA] = b"AcquireSRWLockExclusive\0"
    return bytes(pe)


def test_the_pe_reader_reads_the_imported_dlls_and_functions():
    assert pe_min_os(_hand_made_pe()) == {"os": (6, 0), "subsystem": (6, 1), "imports": ["KERNEL32.dll"],
                                          "functions": {"KERNEL32.dll": ["AcquireSRWLockExclusive", "#7"]}}
    with pytest.raises(ValueError, match="no MZ"):
        pe_min_os(b"ZM" + bytes(100))


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


def _row(text, start):
    """The one line of a docs table that starts with ``start``."""
    (line,) = [ln for ln in text.splitlines() if ln.startswith(start)]
    return line


def _named_dlls(line):
    return {n for n in re.findall(r"`([A-Za-z0-9_.-]+\.dll)`", line)}


def _imports_by_kind(fmus_):
    """{"native"/"pythonfmu": (the DLL names besides the UCRT's api sets, {dll: functions})} of the
    Windows binaries of ``fmus_``, each kind's DLLs alike (checked)."""
    kinds = {}
    for fmu in fmus_:
        for name, data in _binaries(fmu).items():
            if not name.endswith(".dll"):
                continue
            info = pe_min_os(data)
            kind = "pythonfmu" if "python3.dll" in info["imports"] else "native"
            dlls = frozenset(i for i in info["imports"] if not i.startswith("api-ms-win-crt-"))
            if kind in kinds:
                assert kinds[kind][0] == dlls, (fmu.name, name, dlls, kinds[kind][0])
                for dll, funcs in info["functions"].items():
                    kinds[kind][1].setdefault(dll, set()).intersection_update(funcs)
            else:
                kinds[kind] = (dlls, {dll: set(funcs) for dll, funcs in info["functions"].items()})
    return kinds


@pytest.mark.slow
def test_hosts_tables_state_the_windows_runtime_each_dll_imports(fmu_dir, fmu_dir_all_platforms):
    """Each row of docs/hosts.md that says what a Windows binary needs names exactly the DLLs the
    binaries import (besides the UCRT's api sets), and the KERNEL32 functions it names are imported by
    every native DLL: the native FMUs' row of the minimum-system table (the co-simulation pair in both
    FMI versions, the model-exchange plant, the clocked controller), pythonfmu's row of the host table."""
    hosts = (ROOT / "docs" / "hosts.md").read_text()
    fmus_ = [*sorted(fmu_dir.glob("*.fmu")),
             *(f for d in ("native", "native-fmi3", "native-me", "native-me-fmi3", "native-fmi3-clocked")
               for f in sorted((fmu_dir_all_platforms / d).glob("*.fmu")))]
    kinds = _imports_by_kind(fmus_)
    assert set(kinds) == {"native", "pythonfmu"}
    native_row = _row(hosts, "| `win64`, `x86_64-windows`")
    assert _named_dlls(native_row) == set(kinds["native"][0]) == {"KERNEL32.dll"}, native_row
    kernel32 = kinds["native"][1]["KERNEL32.dll"]
    named = set(re.findall(r"`([A-Z][A-Za-z]+)`", native_row))  # the functions the row names
    assert {"AcquireSRWLockExclusive", "ReleaseSRWLockExclusive", "VirtualProtect", "VirtualQuery"} <= named
    assert named <= kernel32, named - kernel32
    pythonfmu_row = _row(hosts, "| pythonfmu FMI 2.0")
    assert _named_dlls(pythonfmu_row) == set(kinds["pythonfmu"][0]), pythonfmu_row


def test_readme_and_hosts_state_the_minimum_of_every_binary():
    readme = (ROOT / "README.md").read_text()
    hosts = (ROOT / "docs" / "hosts.md").read_text()
    for text in (readme, hosts):
        assert re.search(r"macOS 11\b", text)
        assert "glibc 2.17" in text
        assert "Windows 10" in text
    assert native_build.MACOS_MIN == "11.0"

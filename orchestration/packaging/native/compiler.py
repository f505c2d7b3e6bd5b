"""Compile and package native (Python-free) C co-simulation FMUs, FMI 2.0 or FMI 3.0.

An FMU is the model-agnostic glue of ``fmu/native/fmi/`` (``fg_instance.c``, ``fg_state.c`` and
``fmi2_glue.c`` or ``fmi3_glue.c``) linked with the C files of one model implementing ``fg_model.h``.
The model description XML is made in Python by the caller and passed in; its GUID (FMI 2) or
instantiationToken (FMI 3) is compiled into the binary (``-DINSTANTIATION_TOKEN``), which refuses
to instantiate with another one. A placeholder ``{GUID}`` in the XML is replaced by a UUID5 of
everything the FMU is built from, so two builds of the same inputs give the same token.

Linux binaries are built with the host ``gcc`` (or ``cc``); the other platforms are
cross-compiled with ``python -m ziglang cc`` (PyPI ``ziglang``). The ``.fmu`` zip is written
reproducibly, as ``orchestration.packaging.fmu_build.make_reproducible`` does for the pythonfmu FMUs: sorted
entries, fixed timestamps, fixed permissions; the compilers run on relative file names in a
staging directory so no temporary path ends up in a binary.

Entry point: :func:`build_native_fmu`.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import uuid
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from orchestration.packaging.sources import fmu_sources

GLUE_DIR = fmu_sources() / "native" / "fmi"
GUID_PLACEHOLDER = "{GUID}"
ZIP_DATE = (1980, 1, 1, 0, 0, 0)

# -ffp-contract=off: no fused multiply-add (clang fuses by default, and aarch64 has FMA): the same
# arithmetic as the Python core, so results stay bit-identical to it
CFLAGS = ("-std=c99", "-O2", "-shared", "-Wall", "-Wextra", "-Werror", "-pedantic", "-fvisibility=hidden",
          "-ffp-contract=off")


MACOS_MIN = "11.0"  # the declared minimum macOS (LC_BUILD_VERSION minos) of both Mach-O binaries: Big Sur,
# the first macOS on Apple silicon (zig 0.17 would declare 15.0, its default deployment target)


@dataclass(frozen=True)
class Platform:
    fmi2: str | None  # the binaries/ folder of FMI 2.0 (None: FMI 2.0 has no name for it)
    fmi3: str  # the binaries/ folder of FMI 3.0
    suffix: str
    zig_target: str | None  # None: the host C compiler (Linux x86_64)


PLATFORMS = {
    "linux64": Platform("linux64", "x86_64-linux", ".so", None),
    "win64": Platform("win64", "x86_64-windows", ".dll", "x86_64-windows-gnu"),
    "darwin64": Platform("darwin64", "x86_64-darwin", ".dylib", f"x86_64-macos.{MACOS_MIN}"),
    "aarch64-darwin": Platform(None, "aarch64-darwin", ".dylib", f"aarch64-macos.{MACOS_MIN}"),
}
# the FMI 3.0 names are accepted too
ALIASES = {p.fmi3: name for name, p in PLATFORMS.items()}
# FMI 2.0's darwin64: one universal (fat) Mach-O of these thin ones, as the Reference-FMUs ship theirs
# (FMI 2.0 has no folder name for arm64; FMI 3.0 ships them apart, x86_64-darwin and aarch64-darwin)
UNIVERSAL_FMI2 = {"darwin64": ("darwin64", "aarch64-darwin")}
FAT_MAGIC = 0xCAFEBABE
FAT_ALIGN = 14  # log2 of the slices' alignment: 16 KiB, the page size of arm64 macOS (lipo's choice)


def fat_macho(thin: Sequence[bytes]) -> bytes:
    """A universal Mach-O of the 64-bit little-endian ``thin`` ones, in their order: the big-endian
    header (FAT_MAGIC, nfat_arch), a fat_arch each (cputype, cpusubtype from the slice, offset,
    size, align), each slice at a multiple of 2**FAT_ALIGN."""
    step = 1 << FAT_ALIGN
    arches, parts, offset = [], [], step  # the header and its table fit in the first 16 KiB
    for data in thin:
        magic, cputype, cpusubtype = struct.unpack_from("<Iii", data, 0)
        if magic != 0xFEEDFACF:
            raise NativeBuildError(f"not a 64-bit little-endian Mach-O (magic {magic:#x})")
        arches.append(struct.pack(">iiIII", cputype, cpusubtype, offset, len(data), FAT_ALIGN))
        parts.append(data)
        offset += -(-len(data) // step) * step
    head = struct.pack(">II", FAT_MAGIC, len(thin)) + b"".join(arches)
    out = bytearray(head + bytes(step - len(head)))
    for j, data in enumerate(parts):
        out += data if j + 1 == len(parts) else data + bytes(-len(data) % step)
    return bytes(out)


class NativeBuildError(RuntimeError):
    pass


def fmi_headers_dir() -> Path:
    """The FMI 2.0/3.0 headers shipped with fmpy (``fmpy/c-code``)."""
    spec = importlib.util.find_spec("fmpy")
    if spec is None or not spec.origin:
        raise NativeBuildError("fmpy is not installed: its c-code/ holds the FMI headers")
    d = Path(spec.origin).parent / "c-code"
    if not (d / "fmi2Functions.h").is_file():
        raise NativeBuildError(f"no FMI headers in {d}")
    return d


def fmi_headers(fmi_version: str) -> list[Path]:
    d = fmi_headers_dir()
    major = _major(fmi_version)
    return sorted(d.glob(f"fmi{major}*.h"))


def _major(fmi_version: str) -> int:
    major = str(fmi_version).split(".")[0]
    if major not in ("2", "3"):
        raise NativeBuildError(f"fmi_version must be '2.0' or '3.0', not {fmi_version!r}")
    return int(major)


def glue_files(fmi_version: str) -> list[Path]:
    major = _major(fmi_version)
    return [GLUE_DIR / n for n in ("fg_model.h", "fg_model_clock.h", "fg_instance.h", "fg_instance.c",
                                   "fg_state.c", f"fmi{major}_glue.c")]


def _token_attribute(major: int) -> str:
    return "guid" if major == 2 else "instantiationToken"


def read_token(model_description_xml: str, fmi_version: str) -> str:
    """The GUID (FMI 2) or instantiationToken (FMI 3) of a model description."""
    attr = _token_attribute(_major(fmi_version))
    m = re.search(rf'\b{attr}="([^"]*)"', model_description_xml)
    if not m:
        raise NativeBuildError(f"the model description has no {attr} attribute")
    return m.group(1)


def zig_available() -> bool:
    """True if ``python -m ziglang`` runs (the ziglang wheel bundles the compiler; no network needed)."""
    try:
        r = subprocess.run([sys.executable, "-m", "ziglang", "version"], capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0


def host_compiler() -> str | None:
    """The host C compiler for the Linux binaries (``gcc`` or ``cc`` on PATH), or None."""
    for cc in ("gcc", "cc"):
        if shutil.which(cc):
            return cc
    return None


def _compiler(platform: Platform) -> list[str]:
    if platform.zig_target is None:
        cc = host_compiler()
        if cc is None:
            raise NativeBuildError("no C compiler (gcc or cc) on PATH; or `pip install ziglang` and build "
                                   "the Linux binary with linux_glibc")
        return [cc]
    if not zig_available():
        raise NativeBuildError(f"cross-compiling for {platform.fmi3} needs `pip install ziglang`")
    return [sys.executable, "-m", "ziglang", "cc", "-target", platform.zig_target]


def _platform(name: str) -> Platform:
    name = ALIASES.get(name, name)
    if name not in PLATFORMS:
        raise NativeBuildError(f"unknown platform {name!r}; known: {sorted(PLATFORMS)}")
    return PLATFORMS[name]


def compile_binary(staging: Path, c_files: Sequence[str], model_identifier: str, token: str,
                   platform: Platform, out: Path, extra_cflags: Sequence[str] = ()) -> None:
    """Compile the C files (names relative to ``staging``, where the headers are) into ``out``."""
    flags = [*CFLAGS, *extra_cflags]
    libs = [] if platform.suffix == ".dll" else ["-lm"]
    if platform.suffix == ".so":
        flags.insert(0, "-fPIC")
    if platform.zig_target is not None:
        # clang warns on the () prototypes of fmi3FunctionTypes.h; -s drops the debug info and stabs
        # that name the temporary directory (and makes the PE/Mach-O output reproducible)
        flags += ["-Wno-strict-prototypes", "-s"]
        if platform.suffix == ".dylib":  # a fixed install name instead of the output path
            libs.append(f"-Wl,-install_name,@rpath/{model_identifier}.dylib")
    cmd = [*_compiler(platform), *flags, "-I.", f"-DMODEL_IDENTIFIER={model_identifier}",
           f'-DINSTANTIATION_TOKEN="{token}"', *c_files, "-o", str(out), *libs]
    r = subprocess.run(cmd, cwd=staging, capture_output=True, text=True)
    if r.returncode != 0 or not out.is_file():
        raise NativeBuildError(
            f"compilation for {platform.fmi3} failed:\n{' '.join(cmd)}\n{r.stdout}{r.stderr}")


def write_reproducible_zip(files: Mapping[str, bytes], out_path: Path) -> None:
    """Sorted entries, fixed timestamps and permissions (as ``fmu_build.make_reproducible``)."""
    out_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_path.with_name(out_path.name + ".tmp")
    with zipfile.ZipFile(tmp, "w") as z:
        for n in sorted(files):
            info = zipfile.ZipInfo(n, date_time=ZIP_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if n.startswith("binaries/") else 0o644) << 16
            info.create_system = 3
            z.writestr(info, files[n])
    tmp.replace(out_path)


def _resource_files(resources) -> dict[str, bytes]:
    """``resources``: None, a directory, or a mapping of relative name -> bytes/str/Path."""
    if resources is None:
        return {}
    if isinstance(resources, str | Path):
        root = Path(resources)
        return {p.relative_to(root).as_posix(): p.read_bytes()
                for p in sorted(root.rglob("*")) if p.is_file()}
    out = {}
    for name, content in resources.items():
        if isinstance(content, Path):
            content = content.read_bytes()
        elif isinstance(content, str):
            content = content.encode("utf-8")
        out[str(name)] = bytes(content)
    return out


def build_native_fmu(model_identifier: str, sources: Iterable[str | Path], model_description_xml: str,
                     out_path: str | Path, fmi_version: str = "2.0", platforms: Sequence[str] = ("linux64",),
                     resources=None, extra_cflags: Sequence[str] = (), linux_glibc: str | None = None,
                     documentation=None, extra_files=None) -> tuple[Path, str]:
    """Build a native co-simulation FMU; returns ``(path of the .fmu, GUID/instantiationToken)``.

    ``sources``: the model's files (``.c`` compiled, ``.h`` and others only copied), placed flat
    next to the glue in ``sources/`` of the FMU (so ``#include "x.h"`` of any of them works), with
    what makes it a source-code FMU (:mod:`orchestration.packaging.native.source_fmu`: the FMI 2.0 source file
    list, the FMI 3.0 build description, the identity header).
    ``model_description_xml``: the complete modelDescription.xml; its ``modelIdentifier`` must be
    ``model_identifier``; its guid/instantiationToken is compiled in (``{GUID}``: derived from the
    inputs). ``platforms``: keys of :data:`PLATFORMS` (``linux64``, ``win64``, ``darwin64``,
    ``aarch64-darwin``) or FMI 3.0 platform names. ``resources``: a directory or a mapping
    name -> content for ``resources/``. ``linux_glibc`` (e.g. ``"2.17"``): build the Linux binary
    with zig against that glibc (the host gcc links against the host's glibc, 2.29+ for ``exp``
    on Debian 12). ``documentation``: like ``resources``, for ``documentation/`` (e.g.
    ``{"index.html": ...}``). ``extra_files``: ``{path in the FMU: bytes}`` (e.g. FMI 3.0's
    ``terminalsAndIcons/terminalsAndIcons.xml``). Raises :class:`NativeBuildError` on any failure.
    """
    from orchestration.packaging.native import source_fmu  # here: its xml.sax imports urllib, http, ssl

    major = _major(fmi_version)
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", model_identifier):
        raise NativeBuildError(f"model identifier {model_identifier!r} is not a C identifier")
    if f'modelIdentifier="{model_identifier}"' not in model_description_xml:
        raise NativeBuildError(f'the model description has no modelIdentifier="{model_identifier}"')
    plats = [_platform(p) for p in platforms]
    if linux_glibc is not None:  # portable Linux binaries: zig cc against an old glibc instead of the host's
        if not re.fullmatch(r"2\.\d+", linux_glibc):
            raise NativeBuildError(f"linux_glibc must look like '2.17', not {linux_glibc!r}")
        plats = [Platform(p.fmi2, p.fmi3, p.suffix, f"x86_64-linux-gnu.{linux_glibc}") if p.zig_target is None
                 else p for p in plats]
    for p in plats:
        if major == 2 and p.fmi2 is None:
            raise NativeBuildError(f"FMI 2.0 has no platform name for {p.fmi3}")

    src_files: dict[str, bytes] = {}
    for f in [*glue_files(fmi_version), *fmi_headers(fmi_version), *map(Path, sources)]:
        if f.name in src_files:
            raise NativeBuildError(f"two source files named {f.name}")
        src_files[f.name] = f.read_bytes()
    c_files = sorted(n for n in src_files if n.endswith(".c"))

    xml = model_description_xml
    if major == 2:  # a source-code FMU: the C files to compile (FMI 3.0: sources/buildDescription.xml)
        xml = source_fmu.with_source_files(xml, c_files)
    attr = _token_attribute(major)
    if f'{attr}="{GUID_PLACEHOLDER}"' in xml:
        seed = f"{model_identifier}\0{major}\0{sorted(platforms)}\0{list(extra_cflags)}\0{linux_glibc}\0"
        h = hashlib.sha256(seed.encode())
        h.update(xml.encode())
        for n in sorted(src_files):
            h.update(n.encode() + b"\0" + src_files[n] + b"\0")
        token = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "satmotor-native:" + h.hexdigest())) + "}"
        xml = xml.replace(f'{attr}="{GUID_PLACEHOLDER}"', f'{attr}="{token}"', 1)
    token = read_token(xml, fmi_version)
    if '"' in token or "\\" in token:
        raise NativeBuildError(f"{attr} {token!r} cannot be a C string literal as is")

    files: dict[str, bytes] = {"modelDescription.xml": xml.encode("utf-8")}
    files.update({f"sources/{n}": b for n, b in src_files.items()})
    identity = source_fmu.identity_header(model_identifier, token,
                                          [f[2:] for f in extra_cflags if f.startswith("-D")])
    files[f"sources/{source_fmu.IDENTITY_HEADER}"] = identity.encode()
    if major == 3:
        description = source_fmu.build_description(model_identifier, c_files)
        files[f"sources/{source_fmu.BUILD_DESCRIPTION}"] = description.encode()
    files["sources/BUILD.txt"] = source_fmu.build_text(model_identifier, c_files, major).encode()
    files.update({f"resources/{n}": b for n, b in _resource_files(resources).items()})
    files.update({f"documentation/{n}": b for n, b in _resource_files(documentation).items()})
    files.update(extra_files or {})

    with tempfile.TemporaryDirectory(prefix="sm_native_") as tmp:
        staging = Path(tmp) / "src"
        staging.mkdir()
        for n, b in src_files.items():
            (staging / n).write_bytes(b)
        for p in plats:
            outdir = Path(tmp) / "out" / p.fmi3
            outdir.mkdir(parents=True)
            out = outdir / (model_identifier + p.suffix)
            compile_binary(staging, c_files, model_identifier, token, p, out, extra_cflags)
            folder = p.fmi2 if major == 2 else p.fmi3
            data = out.read_bytes()
            if major == 2 and folder in UNIVERSAL_FMI2:
                thin = [data]
                for other in UNIVERSAL_FMI2[folder][1:]:
                    q = PLATFORMS[other]
                    (outdir / q.fmi3).mkdir()
                    extra = outdir / q.fmi3 / (model_identifier + q.suffix)
                    compile_binary(staging, c_files, model_identifier, token, q, extra, extra_cflags)
                    thin.append(extra.read_bytes())
                data = fat_macho(thin)
            files[f"binaries/{folder}/{model_identifier}{p.suffix}"] = data

    out_path = Path(out_path)
    write_reproducible_zip(files, out_path)
    return out_path, token


def build_once(cache_dir, name, inputs, build, text=""):
    """``cache_dir/<key>/<name>``: a native FMU built once by ``build(directory)`` (which returns
    the path of what it built there) and reused while its ``inputs`` (files: the C sources, the
    modules that generate it) and ``text`` (e.g. a profiles file) are unchanged; the key is a
    SHA-256 over them and the glue.  Built aside, then renamed: never half-written."""
    from orchestration.packaging.native import tables as native_tables

    h = hashlib.sha256(text.encode())
    for f in (*inputs, *sorted(GLUE_DIR.glob("*.[ch]")), Path(__file__), *native_tables.GENERATOR_FILES):
        h.update(Path(f).name.encode() + b"\0" + Path(f).read_bytes() + b"\0")
    d = Path(cache_dir) / h.hexdigest()[:24]
    fmu = d / name
    if not fmu.is_file():
        d.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=d) as tmp:
            os.replace(build(tmp), fmu)
    return fmu

"""The engine's shared library: ``sm_engine.c`` compiled once per source content into a cache
directory, the way the native FMUs' Linux binaries are built
(:mod:`orchestration.packaging.native.compiler`: the host's gcc or cc with the FMUs' flags, C99,
warnings as errors, no fused multiply-add; zig's cc when the host has no C compiler).

The cache: ``$SATMOTOR_ENGINE_CACHE``, else ``$XDG_CACHE_HOME/satmotor/engine`` (``~/.cache``); the
library's folder name carries a SHA-256 of the source, the FMI headers and the flags, so a changed
source is built anew, and a build is written under a temporary name and renamed when complete (two
processes building at once both end with a whole library).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from orchestration.packaging.native.compiler import CFLAGS, NativeBuildError, fmi_headers, host_compiler

__all__ = ["SOURCE", "cache_dir", "library_path", "compile_library"]

SOURCE = Path(__file__).with_name("sm_engine.c")
HEADERS = ("fmi2TypesPlatform.h", "fmi2FunctionTypes.h", "fmi3PlatformTypes.h", "fmi3FunctionTypes.h")
NAME = "libsm_engine.dll" if sys.platform == "win32" else "libsm_engine.so"


def cache_dir():
    """The engine's cache directory (the library; the prepared FMUs under ``fmus/``)."""
    given = os.environ.get("SATMOTOR_ENGINE_CACHE")
    if given:
        return Path(given)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "satmotor" / "engine"


def _headers():
    found = {p.name: p for v in ("2.0", "3.0") for p in fmi_headers(v)}
    return [found[n] for n in HEADERS]


def _compiler():
    """The compiler command and its extra flags (zig's clang: the () prototypes of fmi3FunctionTypes.h,
    as the FMUs' cross builds)."""
    cc = host_compiler()
    if cc is not None:
        return [cc], []
    return [sys.executable, "-m", "ziglang", "cc"], ["-Wno-strict-prototypes"]  # the project's zig


def library_path():
    """The compiled library (built first when missing); NativeBuildError says why a build failed."""
    flags = [*CFLAGS, "-fPIC"]
    key = hashlib.sha256(SOURCE.read_bytes() + b"".join(h.read_bytes() for h in _headers())
                         + " ".join(flags).encode()).hexdigest()[:20]
    out = cache_dir() / key / NAME
    if not out.is_file():
        compile_library(out, flags)
    return out


def compile_library(out, flags):
    """Compile :data:`SOURCE` into ``out`` (written under a temporary name, then renamed)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    include = {str(h.parent) for h in _headers()}
    fd, tmp = tempfile.mkstemp(dir=out.parent, suffix=".part")
    os.close(fd)
    cc, extra = _compiler()
    cmd = [*cc, *flags, *extra, *(f"-I{d}" for d in sorted(include)), str(SOURCE), "-o", tmp, "-lm"]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise NativeBuildError(f"compiling the stepping engine failed:\n{' '.join(cmd)}\n"
                                   f"{r.stdout}{r.stderr}")
        os.replace(tmp, out)
    finally:
        Path(tmp).unlink(missing_ok=True)
    return out

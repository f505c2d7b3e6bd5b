"""Lean copies of FMUs for an engine that unpacks every FMU each time it loads a system (libcosim):
only what an importer runs (``modelDescription.xml``, ``binaries/<platform>/``, ``resources/``),
stored uncompressed, built once per FMU content into a cache directory.

The project's native FMUs are source-code FMUs (``sources/``, ``documentation/``): unpacking them
costs libcosim about 50 ms of CPU for the default system's four FMUs, the lean copies about 18 ms
(``bench/RESULTS.md``, section engines); the binaries and the model description are the same
bytes, so a run is the same bit for bit.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import zipfile
from pathlib import Path

__all__ = ["KEPT", "lean_fmu"]

KEPT = ("modelDescription.xml", "binaries/", "resources/")  # what a copy keeps (names or prefixes)


def _kept(name, platform):
    if name == KEPT[0] or name.startswith(KEPT[2]):
        return True
    return name.startswith(f"binaries/{platform}/") if platform else name.startswith(KEPT[1])


def lean_fmu(path, cache_dir, platform="linux64"):
    """The lean copy of the FMU ``path`` in ``cache_dir`` (made when missing; its name carries a
    SHA-256 of the FMU's bytes); ``platform``: the binaries kept (None: all)."""
    data = Path(path).read_bytes()
    key = hashlib.sha256(data + (platform or "").encode()).hexdigest()[:24]
    out = Path(cache_dir) / key / Path(path).name
    if out.is_file():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out.parent, suffix=".part")
    try:
        with os.fdopen(fd, "wb") as fh, zipfile.ZipFile(path) as src, \
                zipfile.ZipFile(fh, "w", zipfile.ZIP_STORED) as z:
            for item in src.infolist():
                if _kept(item.filename, platform):
                    z.writestr(item, src.read(item), compress_type=zipfile.ZIP_STORED)
        os.replace(tmp, out)  # complete, then renamed: never half-written
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return out

"""satmotor: saturated induction motor physics and backstepping control, FMI-agnostic.

Imports numpy only.  The model conventions: docs/model.md.
"""

import hashlib
from pathlib import Path

__version__ = "0.1.0"


def source_fingerprint(*extra_files):
    """SHA-256 (hex) of this package's ``.py`` sources, then of ``extra_files``.

    The FMUs bake it in at build time and compare it at instantiation with the ``satmotor`` they
    actually loaded (pythonfmu shares one interpreter between FMUs, caching modules by name).
    """
    h = hashlib.sha256()
    root = Path(__file__).resolve().parent
    for f in sorted(root.rglob("*.py")):
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    for f in extra_files:
        h.update(Path(f).read_bytes())
    return h.hexdigest()

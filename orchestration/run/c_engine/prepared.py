"""FMUs extracted once per content for the c engine's runs: the files a run needs
(:func:`orchestration.run.fmu_instance.needed_to_run`) and the model description as fmpy reads it, kept
in the engine's cache (:func:`orchestration.run.c_engine.build.cache_dir`, ``fmus/``) under a SHA-256 of
the FMU's bytes and the fmpy version.  A single ``run --engine c`` then spends no time unzipping the two
FMUs and parsing their XML (about 13 ms of the 1.5-s default run's 57, ``bench/bench_c_engine.py``);
the binaries are the same bytes, so the results are the same bit for bit.

An entry is written under a temporary name and renamed when complete: two processes preparing the same
FMU both end with a whole copy, one of them kept.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import shutil
import tempfile
from pathlib import Path

import fmpy
from fmpy import read_model_description

from orchestration.run.c_engine.build import cache_dir
from orchestration.run.fmu_instance import needed_to_run

__all__ = ["prepared", "description"]

DESCRIPTION = "modelDescription.pickle"


def prepared(path):
    """``(unzip directory, model description)`` of the FMU ``path``, extracted and read once per content."""
    data = Path(path).read_bytes()
    key = hashlib.sha256(data + fmpy.__version__.encode()).hexdigest()[:24]
    root = cache_dir() / "fmus"
    entry = root / key
    if not (entry / DESCRIPTION).is_file():
        root.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".part-", dir=root))
        try:
            fmpy.extract(str(path), unzipdir=str(tmp), include=needed_to_run)
            md = read_model_description(str(path))
            (tmp / DESCRIPTION).write_bytes(pickle.dumps(md))
            try:
                os.rename(tmp, entry)
            except OSError:  # another process made it first: keep its copy
                if not (entry / DESCRIPTION).is_file():
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    # the cache is this user's own directory, written above from the FMU whose bytes name it
    return str(entry), pickle.loads((entry / DESCRIPTION).read_bytes())  # noqa: S301


def description(path):
    """The model description of the FMU ``path`` as fmpy reads it, parsed once per content and kept in
    the engine's cache (``descriptions/``; the same key as :func:`prepared`): the checks of a scenario
    read the FMUs' variables without parsing their XML each run.  Where the cache cannot be written,
    the description is read from the FMU."""
    data = Path(path).read_bytes()
    key = hashlib.sha256(data + fmpy.__version__.encode()).hexdigest()[:24]
    kept = cache_dir() / "descriptions" / f"{key}.pickle"
    try:
        # the cache is this user's own directory, written below from the FMU whose bytes name it
        return pickle.loads(kept.read_bytes())  # noqa: S301
    except (OSError, EOFError, pickle.UnpicklingError):
        pass
    md = read_model_description(str(path))
    try:
        kept.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".part-", dir=kept.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(pickle.dumps(md))
            os.replace(tmp, kept)
        finally:
            Path(tmp).unlink(missing_ok=True)
    except OSError:
        pass
    return md

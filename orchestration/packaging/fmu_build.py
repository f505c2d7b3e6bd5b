"""Build the two FMI 2.0 co-simulation FMUs with pythonfmu, bundling the satmotor package.

Usage::

    python build_fmus.py [--out DIR] [--all-platforms]        # in a checkout; default build/fmus/
    python -m orchestration.packaging.fmu_build [--out DIR] [--all-platforms]
    satmotor-cosim build [--out DIR] [--all-platforms]

For this machine (Linux x86_64) by default; ``--all-platforms`` cross-compiles the native FMUs for
Windows and macOS too (zig, from the ``ziglang`` wheel): what ``make dist`` builds.

The FMU sources (``fmu/common``, ``fmu/plant``, ``fmu/controller``) are installed with the
package as ``satmotor_fmu_sources``, so an installed ``satmotor-cosim`` builds the FMUs outside a
checkout too.

Each FMU is built in a child process (pythonfmu imports the slave script to read its variables,
and a later simulation in the same process would otherwise run the cached build copy); its model
description is completed (units, default experiment, version, license, model structure:
``orchestration.packaging.fmu_model_description``), then the FMU is made reproducible: fixed timestamps,
sorted zip entries, and a GUID derived from the content, so two builds from the same commit give
the same model description and GUID.
"""

from __future__ import annotations

import argparse
import hashlib
import re
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path

import satmotor
from orchestration.packaging import documentation as documentation_module
from orchestration.packaging import sources as sources_module
from orchestration.packaging.documentation import documentation
from orchestration.packaging.fmu_model_description import complete as complete_model_description
from orchestration.packaging.sources import COMMON_OPTIONS, FMUS, GLUE, SATMOTOR

FIXED_DATE = "2026-01-01T00:00:00Z"

# inside each FMU: the GUID its build wrote into modelDescription.xml.  pythonfmu does not pass the host's
# fmuGUID to Python, so the glue compares this file with the modelDescription.xml next to resources/ and
# refuses to instantiate a copy whose description carries another GUID (satmotor_fmu_glue.BUILD_GUID_FILE)
BUILD_GUID = "resources/build_guid.txt"


def make_reproducible(src, dst, extra_files=None):
    """Rewrite the FMU zip deterministically; the GUID is a UUID5 of the content (all files but
    :data:`BUILD_GUID`, which is written last, holding that GUID). Returns it."""
    with zipfile.ZipFile(src) as z:
        files = {n: z.read(n) for n in z.namelist() if not n.endswith("/") and "__pycache__" not in n}
    files.update(extra_files or {})
    md = files["modelDescription.xml"].decode("utf-8")
    md = re.sub(r'generationDateAndTime="[^"]*"', f'generationDateAndTime="{FIXED_DATE}"', md, count=1)
    md = re.sub(r'guid="[^"]*"', 'guid="{GUID}"', md, count=1)
    h = hashlib.sha256()
    files.pop(BUILD_GUID, None)
    for n in sorted(files):
        h.update(n.encode() + b"\0" + (md.encode() if n == "modelDescription.xml" else files[n]) + b"\0")
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, h.hexdigest())) + "}"
    files["modelDescription.xml"] = md.replace('guid="{GUID}"', f'guid="{guid}"', 1).encode("utf-8")
    files[BUILD_GUID] = (guid + "\n").encode("utf-8")
    with zipfile.ZipFile(dst, "w") as z:
        for n in sorted(files):
            info = zipfile.ZipInfo(n, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            info.create_system = 3
            z.writestr(info, files[n])
    return guid


BUILD_INPUTS = "resources/build_inputs.sha256"  # inside each FMU: what it was built from


def inputs_fingerprint(name):
    """SHA-256 over everything the FMU ``name`` is built from: the satmotor package, the glue, its
    slave script and this build logic (so a change to any of them makes a built FMU stale)."""
    from orchestration.packaging import fmu_model_description

    h = hashlib.sha256(satmotor.source_fingerprint(GLUE).encode())
    for f in (FMUS[name][0], Path(__file__), Path(fmu_model_description.__file__),
              Path(sources_module.__file__), Path(documentation_module.__file__)):
        h.update(Path(f).read_bytes())
    return h.hexdigest()


def build_one(name, out_dir):
    """Build one FMU (call in a fresh process: pythonfmu imports the slave script)."""
    from pythonfmu.builder import FmuBuilder

    sys.path.insert(0, str(GLUE.parent))
    import satmotor_fmu_glue

    script, _, _, options = FMUS[name]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        staged = tmp / script.name
        fp = satmotor_fmu_glue.fingerprint()
        staged.write_text(script.read_text().replace("@SATMOTOR_FINGERPRINT@", fp))
        shutil.copy(GLUE, tmp / GLUE.name)
        pkg = tmp / "satmotor"
        shutil.copytree(SATMOTOR, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        raw = FmuBuilder.build_FMU(staged, dest=tmp / "raw", project_files={pkg, tmp / GLUE.name},
                                   **COMMON_OPTIONS, **options)
        doc = documentation(name).encode("utf-8")
        with zipfile.ZipFile(raw) as z:
            md = complete_model_description(name, z.read("modelDescription.xml"))
        out = Path(out_dir) / f"{name}.fmu"
        guid = make_reproducible(raw, out, {"documentation/index.html": doc, "modelDescription.xml": md,
                                            BUILD_INPUTS: (inputs_fingerprint(name) + "\n").encode()})
    print(f"built {out}  guid {guid}")
    return out


def build_all(out_dir="build/fmus", native=True, cross=False):
    """Build both pythonfmu FMUs into ``out_dir`` (each in a child process) and, with ``native``, the
    native ones into ``out_dir/native`` (FMI 2.0) and ``out_dir/native-fmi3`` (FMI 3.0), the
    model-exchange plant and the clocked controller (``native-fmi3-clocked``,
    :mod:`orchestration.packaging.native.clocked`): for this
    machine (Linux x86_64) by default; with ``cross`` for every platform of
    :data:`orchestration.packaging.native.fmus.ALL` too (Windows and macOS cross-compiled with zig, the Linux
    binary linked against glibc 2.17: the distributable FMUs).  Returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in FMUS:
        subprocess.run([sys.executable, "-m", "orchestration.packaging.fmu_build", "--one", name,
                        "--out", str(out)], check=True)
        paths.append(out / f"{name}.fmu")
    if native:
        from orchestration.packaging.native import clocked
        from orchestration.packaging.native import fmus as native_fmus
        from orchestration.packaging.native import model_exchange as native_me

        cross = native_fmus.zig_available() if cross is None else cross
        for p in [*native_fmus.build_all(out, cross), *native_me.build_all(out, cross),
                  *clocked.build_all(out, cross)]:
            print(f"built {p}")
            paths.append(p)
    return paths


#: the one line printed when the distributable build cannot cross-compile
NO_ZIG = ("--all-platforms cross-compiles the Windows and macOS binaries with zig, which is not installed: "
          'pip install ziglang (or pip install "satmotor[native]")')


def main(argv=None):
    ap = argparse.ArgumentParser(description="Build SaturatedInductionMotor.fmu and "
                                 "BacksteppingController.fmu: FMI 2.0 co-simulation with pythonfmu in OUT, "
                                 "native C ones in OUT/native (FMI 2.0) and OUT/native-fmi3 (FMI 3.0), the "
                                 "model-exchange plant in OUT/native-me and OUT/native-me-fmi3, the "
                                 "clocked controller in OUT/native-fmi3-clocked, for "
                                 "this machine (Linux x86_64); --all-platforms adds Windows and macOS.")
    ap.add_argument("--out", default="build/fmus", help="output directory (default build/fmus)")
    ap.add_argument("--no-native", action="store_true", help="only the pythonfmu FMUs")
    ap.add_argument("--all-platforms", action="store_true",
                    help="native FMUs for Linux, Windows and macOS (cross-compiled with zig; the Linux "
                    "binary for glibc 2.17 and later): the distributable FMUs, as `make dist` builds them")
    ap.add_argument("--no-cross", action="store_true", help="native FMUs for Linux only (the default)")
    ap.add_argument("--one", choices=sorted(FMUS), help=argparse.SUPPRESS)  # internal: build one, in-process
    args = ap.parse_args(argv)
    if args.one:
        build_one(args.one, args.out)
        return 0
    cross = args.all_platforms and not args.no_native
    if cross:
        from orchestration.packaging.native.compiler import zig_available

        if not zig_available():
            print(NO_ZIG, file=sys.stderr)
            return 1
    build_all(args.out, native=not args.no_native, cross=cross)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The probes of what an importing engineer meets beyond the FMI calls (run by
:mod:`orchestration.check.probes` in its child process, as the others):

* ``steps``: the communication steps hosts make (:func:`probe_steps`);
* ``source-build``: a source-code FMU built from its ``sources/`` alone (:func:`probe_source_build`).
"""

from __future__ import annotations

import math
import shutil
import subprocess
import tempfile
from pathlib import Path

from fmpy import platform, platform_tuple

from orchestration.check.probes import Probe, alive, main, status_of

RUN_STEPS = 20  # steps compared between the shipped binary and the one built from the sources
BUILD_BAND = 1e-9  # a binary built from the sources: its outputs within this of the shipped one's (relative)


def _after(p, steps):
    """A fresh instance after ``steps`` (``(t, h)`` pairs) with the input values held: the status of the
    last step, the outputs (bit patterns) and the log of the instance."""
    s = p.instance()
    vrs, values = [v.valueReference for v in p.inputs], p.input_values()
    if vrs:
        s.set_reals(vrs, values)
    p.log.clear()
    status = "ok"
    for t, h in steps:
        status, _ = status_of(s.do_step, t, h)
        if status != "ok":
            break
    out = [x.hex() for x in s.get_reals(p.outputs)] if status in ("ok", "warning") and p.outputs else []
    log = p.errors()
    if status != "fatal":
        s.free()
    return status, out, log


def probe_steps(p):
    """The communication steps hosts make, each on a fresh instance with the inputs held, against the
    same time span in steps of the default experiment's step size h: a step of 2 h (the FMU Compliance
    Checker's default is 2e-4 s, twice our controller's sample period), a step 4 ulps longer than h (a
    host whose time is a float sum, or who passes the difference of two grid times), a step of 1.5 h
    (not a whole multiple: an FMU that cannot handle variable steps may refuse it, with a message)."""
    h = p.h
    ulp_off = h
    for _ in range(4):
        ulp_off = math.nextafter(ulp_off, math.inf)
    _, ref2, _ = _after(p, [(0.0, h), (h, h)])
    _, ref1, _ = _after(p, [(0.0, h)])
    out = {"h": h, "variable": bool(p.md.coSimulation.canHandleVariableCommunicationStepSize)}
    for key, steps, ref in (("multiple", [(0.0, 2 * h)], ref2), ("ulp-off", [(0.0, ulp_off)], ref1),
                            ("refused", [(0.0, 1.5 * h)], None)):
        status, got, log = _after(p, steps)
        out[key] = {"step": steps[-1][1], "status": status, "log": log[:300],
                    "same": None if ref is None or status != "ok" else got == ref}
    out["alive"] = alive(p)
    return out


def _compile(unzip, md):
    """Build ``binaries/<this platform>/<modelIdentifier>.so`` in the unpacked FMU ``unzip`` from its
    sources with gcc: the listed C files, the build description's definitions and include directories,
    nothing else.  Returns ``(command, None)`` or ``(command, why it failed)``."""
    config = md.buildConfigurations[0]
    files, flags = [], []
    for fs in config.sourceFileSets:
        files += fs.sourceFiles
        flags += [f"-D{d.name}" + (f"={d.value}" if d.value is not None else "")
                  for d in fs.preprocessorDefinitions if not d.optional]
        flags += [f"-I{d}" for d in fs.includeDirectories]
    ident = md.coSimulation.modelIdentifier
    folder = platform if md.fmiVersion.startswith("2") else platform_tuple
    target = unzip / "binaries" / folder / f"{ident}.so"
    target.parent.mkdir(parents=True, exist_ok=True)
    cmd = ["gcc", "-shared", "-fPIC", *flags, *files, "-o", str(target), "-lm"]
    r = subprocess.run(cmd, cwd=unzip / "sources", capture_output=True, text=True)
    shown = " ".join(["gcc", "-shared", "-fPIC", *flags, f"<{len(files)} files>", "-lm"])
    if r.returncode != 0 or not target.is_file():
        return shown, (r.stderr or r.stdout).strip()[-300:] or f"exit status {r.returncode}"
    return shown, None


def probe_source_build(p):
    """Unpack the FMU without its binaries, build this platform's binary from ``sources/`` with gcc
    (the FMI 2.0 ``<SourceFiles>`` or the FMI 3.0 ``sources/buildDescription.xml``), and run it RUN_STEPS
    steps next to the shipped binary (when there is one for this platform), with the inputs held."""
    if not platform.startswith("linux"):
        return {"skip": f"source-build runs on Linux only (this is {platform})"}
    sources = Path(p.unzip) / "sources"
    has_sources = sources.is_dir() and any(sources.glob("*.c"))
    if not p.md.buildConfigurations:
        if has_sources:
            return {"unlisted": True, "detail": "sources/ holds C files but no file list (FMI 2.0 "
                                                "<SourceFiles>, FMI 3.0 sources/buildDescription.xml): a "
                                                "tool cannot build it unaided"}
        return {"skip": "no sources (a binary-only FMU)"}
    if shutil.which("gcc") is None:
        return {"skip": "gcc is not installed"}
    work = Path(tempfile.mkdtemp(prefix="fmucheck_src_"))
    try:
        built = work / "fmu"
        shutil.copytree(p.unzip, built, ignore=shutil.ignore_patterns("binaries"))
        shown, failure = _compile(built, p.md)
        if failure:
            return {"ok": False, "detail": f"{shown} in sources/ failed: {failure}"}
        archive = shutil.make_archive(str(work / "built"), "zip", built)
        fmu = work / "built.fmu"
        Path(archive).rename(fmu)
        q = Probe(fmu)
        try:
            got = q.run(q.instance(), 0, RUN_STEPS)
        finally:
            shutil.rmtree(q.unzip, ignore_errors=True)
        shipped = Path(p.unzip) / "binaries" / (platform if p.major == 2 else platform_tuple)
        if not (shipped / f"{p.md.coSimulation.modelIdentifier}.so").is_file():
            return {"built": shown, "shipped": False, "steps": RUN_STEPS}
        want = p.run(p.instance(), 0, RUN_STEPS)
        worst = max((abs(float.fromhex(a) - float.fromhex(b)) / max(abs(float.fromhex(b)), 1e-300)
                     for ra, rb in zip(got, want) for a, b in zip(ra, rb) if a != b), default=0.0)
        return {"built": shown, "shipped": True, "steps": RUN_STEPS, "identical": got == want, "worst": worst}
    finally:
        shutil.rmtree(work, ignore_errors=True)


PROBES = {"steps": probe_steps, "source-build": probe_source_build}


if __name__ == "__main__":  # a child process of the checker, as the probes of orchestration.check.probes
    import sys

    main(sys.argv[1:], PROBES)

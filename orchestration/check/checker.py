"""``satmotor-cosim check FMU... [--junit FILE] [--reference DIR]``: checks any FMI 2.0 or FMI 3.0
co-simulation FMU (ours or anyone's) the way an importing tool or a CI job would, one line per check::

    PASS|FAIL|SKIP|KNOWN  <fmu>  <check>: <detail>

``validate`` (fmpy) and ``fmutool`` (fmu-manipulation-toolbox) read the archive in this process; the
run-time checks each run in a child process (:mod:`orchestration.check.probes`), so a crash of the
FMU is a FAIL, not the end of the checker; ``non-finite-input`` and ``foreign-state`` try one item
(an input, a state blob) at a time, and a crash FAILs naming the item and the signal.
``wrong-guid``: instantiation with a GUID (FMI 3.0: instantiationToken) that is not the model
description's must be refused (KNOWN for pythonfmu FMUs: pythonfmu does not pass it to Python).
``foreign-state``: the serialized state of every other FMU of the same command (another GUID), and
the FMU's own blob truncated and with every byte inverted, must be refused (error or discard), not
crash, and leave the instance usable.  ``steps``: the communication steps hosts make (2 h, h + 4 ulps,
1.5 h; h the default experiment's step size), see :func:`judge_steps`.  ``source-build``: the FMU's
``sources/`` built alone with gcc and run next to the shipped binary (:func:`judge_source_build`).
``reference`` runs the FMU against
``reference/<modelName>/`` (cross-check layout) when that directory exists (ours), else SKIP.
``fmutool`` is FMI 2.0 only (SKIP for FMI 3.0); the other checks run on both versions.  Another
FMI version (1.0) gets ``validate`` only.  An FMU with ``<ModelExchange>`` also gets the
model-exchange checks ``me-instantiate``, ``me-states``, ``me-events``, ``me-reference``
(:mod:`orchestration.check.model_exchange`); a model-exchange-only FMU SKIPs the co-simulation ones.
KNOWN: a known limitation, reported, not failing.
Exit: 1 if any check FAILs, else 0 (usage errors, 2, are found by the caller before any check).
"""

from __future__ import annotations

import tempfile
import time
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from orchestration.check.children import TIMEOUT, died, reference_dir, run_probe_lines  # noqa: F401

CHECKS = ("validate", "fmutool", "instantiate", "wrong-guid", "cycles", "state", "foreign-state", "reset",
          "bad-parameter", "non-finite-input", "steps", "source-build", "reference")
PROBED = CHECKS[2:]
ITEMIZED = ("non-finite-input", "foreign-state")  # probes that try one item at a time


def _reference_dir():
    """The reference results: the installed ``satmotor_reference`` package (``reference/`` of the
    checkout, packed by pyproject.toml), else the checkout's ``reference/``."""
    import importlib.util

    spec = importlib.util.find_spec("satmotor_reference")
    for location in (spec.submodule_search_locations or []) if spec else []:
        if Path(location).is_dir():
            return Path(location).resolve()
    return Path(__file__).resolve().parents[2] / "reference"


REFERENCE_DIR = _reference_dir()
REFERENCE_BAND = 1e-9  # of each column's largest |value|


def usage_problem(path):
    """Why ``path`` cannot be checked at all (missing, not a zip), or None."""
    p = Path(path)
    if not p.is_file():
        return f"{path}: no such file"
    if not zipfile.is_zipfile(p):
        return f"{path}: not a zip archive (an FMU is one)"
    return None


def fmi_version(path):
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    return root.get("fmiVersion", ""), root


def structure_problems(root):
    """FMI 2.0 ModelStructure indices that do not point where they must (an Outputs entry to an
    output, every index and dependency to an existing variable), read from the XML itself: fmpy's
    reader stops at the first out-of-range index with a bare IndexError."""
    if root.get("fmiVersion", "").split(".")[0] != "2":
        return []
    variables = root.findall("./ModelVariables/ScalarVariable")
    n, out = len(variables), []
    for section in ("Outputs", "Derivatives", "InitialUnknowns"):
        for u in root.findall(f"./ModelStructure/{section}/Unknown"):
            refs = [u.get("index", "")] + (u.get("dependencies") or "").split()
            for ref in refs:
                if not ref.isdigit() or not 1 <= int(ref) <= n:
                    out.append(f"ModelStructure/{section}: index {ref!r} is not one of the {n} variables")
            idx = u.get("index", "")
            if (section == "Outputs" and idx.isdigit() and 1 <= int(idx) <= n
                    and variables[int(idx) - 1].get("causality") != "output"):
                name = variables[int(idx) - 1].get("name")
                out.append(f"ModelStructure/Outputs: index {idx} is {name!r}, not an output")
    return out


def check_validate(path):
    from fmpy.validation import validate_fmu

    problems = structure_problems(fmi_version(path)[1])
    try:
        problems += [p for p in validate_fmu(str(path)) if p not in problems]
    except Exception as exc:  # noqa: BLE001 - fmpy's reader on a malformed description
        problems.append(f"fmpy.validation.validate_fmu: {type(exc).__name__}: {exc}")
    if problems:
        return "FAIL", f"{len(problems)} problem(s): " + "; ".join(str(p).strip() for p in problems)[:500]
    return "PASS", "fmpy.validation.validate_fmu: no problems"


def check_fmutool(path):
    try:
        from fmu_manipulation_toolbox.assistant.fmutools import check_fmu
    except ImportError:
        return "SKIP", "fmu-manipulation-toolbox is not installed (pip install \"satmotor[check]\")"

    report = check_fmu(Path(path))
    if report.get("compliant") and report.get("error_count", 0) == 0:
        return "PASS", "fmu-manipulation-toolbox check_fmu: compliant, 0 errors"
    return "FAIL", f"fmu-manipulation-toolbox check_fmu: {report}"[:500]


def run_probe(mode, path, *extra):
    """``(returncode, result dict or None, stderr tail)`` of one child probe."""
    from orchestration.check.user_probes import PROBES as USER_PROBES

    module = "orchestration.check.user_probes" if mode in USER_PROBES else "orchestration.check.probes"
    code, objects, tail = run_probe_lines(mode, path, *extra, module=module)
    return code, (objects[-1] if objects else None), tail


def run_items(mode, path, *extra):
    """``(result dict or None, failure detail or None)`` of an itemized probe: a child that dies
    while trying item i has that item recorded as ``{"crash": how it died}`` and is started again
    from item i + 1; the items' results are merged into the last child's result (``results``)."""
    items, start = {}, 0
    while True:
        code, objects, tail = run_probe_lines(mode, path, start, *extra)
        trying, result = None, None
        for obj in objects:
            if "trying" in obj:
                trying = obj
            elif "item" in obj:
                items[obj["label"]] = obj["result"]
                trying = None
            else:
                result = obj
        if code == 0 and result is not None:
            if "results" in result:
                result["results"] = {**items, **result["results"]}
            return result, None
        if trying is None:
            return None, died(code, tail) if code != 0 else f"no result from the probe: {tail}"
        items[trying["label"]] = {"crash": died(code, tail)}
        start = trying["trying"] + 1


def judge(check, result):
    """``(verdict, detail)`` from a probe's JSON result (the child exited with 0)."""
    if "skip" in result:
        return "SKIP", result["skip"]
    if result.get("ok") is False:
        return "FAIL", result.get("detail", "")
    if check == "bad-parameter":
        st, head = result["status"], f"{result['param']}: {result['status']} at {result['where']}"
        tail = "; a fresh instance then steps fine" if result["alive"] else "; a fresh instance FAILS"
        if not result["alive"]:
            return "FAIL", head + tail
        if st in ("error", "discard"):
            return "PASS", head + tail
        if st == "logged" and "pythonfmu" in result["generationTool"].lower():
            return "KNOWN", head + tail + (" (refused at the next doStep, fmi2Discard naming it: "
                                           "exitInitializationMode logs the error and returns fmi2OK, "
                                           "pythonfmu's limit, it cannot return fmi2Error from Python; a "
                                           "host that reads only that status misses it: the native FMU "
                                           "returns fmi2Error there)")
        if st == "logged":
            return "FAIL", head + tail + " (an error logged, but the call returned OK: expected an error)"
        if st == "fatal" and "pythonfmu" in result["generationTool"].lower():
            return "KNOWN", head + tail + " (pythonfmu reports fmi2Fatal, never fmi2Error: known limitation)"
        if st == "fatal":
            fmi = result.get("fmi", "fmi2")
            return "FAIL", head + tail + f" ({fmi}Fatal for a bad parameter: expected {fmi}Error)"
        return "FAIL", head + " (the FMU accepted it)"
    if check == "non-finite-input":
        res = {k: v["crash"] if isinstance(v, dict) else v for k, v in result["results"].items()}
        bad = {k: v for k, v in res.items() if v not in ("discard", "error")}
        detail = ", ".join(f"{k}=NaN: {v}" for k, v in res.items())
        if not result["alive"]:
            return "FAIL", detail + "; a fresh instance FAILS"
        return ("FAIL" if bad else "PASS"), detail + "; a fresh instance then steps fine"
    if check == "wrong-guid":
        head = f"{result['token']} {result['wrong']} (the model description has {result['guid']})"
        if result["refused"]:
            return "PASS", f"instantiation with {head} refused: {result['detail']}"[:500]
        if "pythonfmu" in result["generationTool"].lower():
            return "KNOWN", (f"instantiated with {head}: pythonfmu's fmi2Instantiate does not pass fmuGUID "
                             f"to the Python slave, so no pythonfmu FMU can refuse it (known limitation)")
        return "FAIL", f"instantiated with {head}: the FMU does not compare the host's {result['token']}"
    if check == "foreign-state":
        return judge_foreign_state(result)
    if check == "steps":
        return judge_steps(result)
    if check == "source-build":
        return judge_source_build(result)
    if check == "reference":
        dev, worst = result.get("dev"), result.get("worst")
        if dev is None:
            return "FAIL", result.get("detail", "")
        verdict = "PASS" if dev[worst] <= REFERENCE_BAND else "FAIL"
        return verdict, (f"{len(dev)} outputs over {result['rows']} rows, worst {worst} "
                         f"{dev[worst]:.3g} of max|ref| (band {REFERENCE_BAND:g})")
    return ("PASS" if result.get("ok") else "FAIL"), result.get("detail", "")


def judge_steps(result):
    """Per step pattern of the ``steps`` probe: a step of 2 h accepted (PASS) or refused by an FMU that
    declares it cannot handle variable steps (KNOWN: such hosts as the FMU Compliance Checker, default
    step 2e-4 s, then fail it); a step a few ulps off h accepted (else FAIL: a host whose time is a
    float sum drifts so); a step of 1.5 h accepted, or refused with a message by a fixed-step FMU (PASS;
    refused by a variable-step one, or without a message: FAIL).  Any fatal status, or a fresh instance
    that cannot step afterwards: FAIL."""
    h, variable = result["h"], result["variable"]
    verdicts, parts = [], []
    for key, label in (("multiple", "2 h"), ("ulp-off", "h + 4 ulps"), ("refused", "1.5 h")):
        r = result[key]
        st, text = r["status"], f"{label} = {r['step']!r} s: {r['status']}"
        if st in ("ok", "warning"):
            verdict = "PASS"
            if r["same"] is not None:
                text += ", bit-identical to the same span in steps of h" if r["same"] else \
                        ", differs from the same span in steps of h"
            if key == "refused":
                text += " (accepted)"
        elif st == "fatal":
            verdict, text = "FAIL", text + " (the instance is lost)"
        elif key == "multiple" and not variable:
            verdict, text = "KNOWN", text + (" (canHandleVariableCommunicationStepSize = false; a host "
                                             "stepping by 2e-4 s, as the FMU Compliance Checker does, "
                                             "fails it)")
        elif key == "ulp-off":
            verdict, text = "FAIL", text + " (a host whose time is a float sum drifts off h by ulps)"
        elif key == "refused" and not variable and r["log"]:
            verdict, text = "PASS", text + f", refused with: {r['log'][:160]}"
        else:
            verdict = "FAIL"
            text += (" without a message" if not r["log"]
                     else " (canHandleVariableCommunicationStepSize = true)")
        verdicts.append(verdict)
        parts.append(text)
    if not result["alive"]:
        verdicts.append("FAIL")
        parts.append("a fresh instance then FAILS")
    verdict = "FAIL" if "FAIL" in verdicts else "KNOWN" if "KNOWN" in verdicts else "PASS"
    return verdict, f"h = {h:g} s; " + "; ".join(parts)


def judge_source_build(result):
    """KNOWN: C files in sources/ but no list of them; PASS: the binary built from the sources runs, and
    gives the shipped binary's outputs (bit for bit, or within BUILD_BAND); else FAIL."""
    from orchestration.check.user_probes import BUILD_BAND

    if result.get("unlisted"):
        return "KNOWN", result["detail"]
    head = f"built with `{result['built']}` in sources/"
    if not result["shipped"]:
        return "PASS", head + (f"; it ran {result['steps']} steps (no shipped binary for this platform to "
                               "compare)")
    if result["identical"]:
        return "PASS", head + f"; {result['steps']} steps bit-identical to the shipped binary"
    verdict = "PASS" if result["worst"] <= BUILD_BAND else "FAIL"
    return verdict, head + (f"; {result['steps']} steps, outputs within {result['worst']:.3g} of the shipped "
                            f"binary's (relative; band {BUILD_BAND:g})")


def judge_foreign_state(result):
    """FAIL if a blob was accepted, crashed the FMU, made it fatal, or left it unusable; KNOWN if a
    pythonfmu FMU refused one through its log only (pythonfmu returns fmi2OK from fmi2DeSerializeFMUstate
    and fmi2SetFMUstate whatever Python does; the next doStep discards); else PASS."""
    pythonfmu = "pythonfmu" in result.get("generationTool", "").lower()
    verdicts, parts = [], []
    for label, r in result["results"].items():
        if "crash" in r:
            verdicts.append("FAIL")
            parts.append(f"{label}: {r['crash']}")
            continue
        outcome = r["outcome"]
        how = f"deserialize {r['deserialize']}" + (f", set {r['set']}" if r["set"] else "")
        if outcome == "refused":
            verdict, text = "PASS", f"refused ({how})"
        elif outcome == "log-only" and pythonfmu:
            verdict, text = "KNOWN", f"refused in the log only ({how}; the next doStep {r['next_step']})"
        elif outcome == "log-only":
            verdict, text = "FAIL", f"refused in the log only ({how}): the host is told OK"
        elif outcome == "fatal":
            verdict, text = "FAIL", f"fatal ({how}): the instance is lost"
        else:
            verdict, text = "FAIL", f"ACCEPTED ({how}, nothing logged): a state not its own was taken"
        if outcome != "fatal" and not r["usable"]:
            verdict, text = "FAIL", text + f"; the instance is not usable after it: {r.get('why', '')}"
        verdicts.append(verdict)
        parts.append(f"{label}: {text}")
    verdict = "FAIL" if "FAIL" in verdicts else "KNOWN" if "KNOWN" in verdicts else "PASS"
    detail = "; ".join(parts)
    if all(r.get("usable") for r in result["results"].values()):
        detail += "; after each, the instance set back to its own state replays it bit-identical"
    if verdict == "KNOWN":
        detail += (" (pythonfmu returns fmi2OK from fmi2DeSerializeFMUstate and fmi2SetFMUstate whatever the "
                   "Python slave does: known limitation)")
    return verdict, detail


def check_fmu(path, references=(REFERENCE_DIR,), foreign=()):
    """``[(check, verdict, detail, seconds)]`` for one FMU.  ``foreign``: ``(label, file)`` of
    serialized states of other FMUs, offered by ``foreign-state``."""
    out = []

    def record(check, f, *args):
        t0 = time.perf_counter()
        try:
            verdict, detail = f(*args)
        except Exception as exc:  # the checker itself could not read the FMU: a FAIL of that check
            verdict, detail = "FAIL", f"{type(exc).__name__}: {exc}"
        out.append((check, verdict, detail, time.perf_counter() - t0))

    def probe(check, *extra):
        if check in ITEMIZED:
            result, failure = run_items(check, path, *extra)
            return ("FAIL", failure) if result is None else judge(check, result)
        code, result, tail = run_probe(check, path, *extra)
        if code != 0 or result is None:
            return "FAIL", died(code, tail) if code != 0 else f"no result from the probe: {tail}"
        return judge(check, result)

    try:
        version, root = fmi_version(path)
    except (KeyError, ET.ParseError) as exc:
        version, root = "", None
        out.append(("modelDescription", "FAIL", f"cannot read modelDescription.xml: {exc}", 0.0))
    record("validate", check_validate, path)
    if root is None:
        return out
    major = version.split(".")[0]
    if major not in ("2", "3"):
        why = f"FMI {version}: only fmpy validate is run (the other checks are FMI 2.0 and 3.0)"
        return out + [(c, "SKIP", why, 0.0) for c in CHECKS[1:]]
    if major == "2":
        record("fmutool", check_fmutool, path)
    else:
        out.append(("fmutool", "SKIP", f"FMI {version}: fmu-manipulation-toolbox check_fmu is FMI 2.0 only",
                    0.0))
    if root.find("ModelExchange") is not None:  # its own checks (orchestration/check/model_exchange.py)
        from orchestration.check.model_exchange import check_model_exchange

        out += check_model_exchange(path, root, references)
    if root.find("CoSimulation") is None:
        return out + [(c, "SKIP", "no CoSimulation element (model exchange only)", 0.0) for c in PROBED]
    offers = [x for label, f in foreign for x in (label, f)]
    for check in PROBED[:-1]:
        record(check, probe, check, *(offers if check == "foreign-state" else ()))
    ref = reference_dir(root, references)
    if ref is None:
        out.append(("reference", "SKIP", f"no reference/{root.get('modelName')}/ (not one of ours)", 0.0))
    else:
        record("reference", probe, "reference", ref)
    return out


def junit(results, file):
    """JUnit XML: one testsuite per FMU, one testcase per check."""
    suites = ET.Element("testsuites", name="satmotor-cosim check")
    for fmu, rows in results.items():
        suite = ET.SubElement(suites, "testsuite", name=str(fmu), tests=str(len(rows)),
                              failures=str(sum(r[1] == "FAIL" for r in rows)), errors="0",
                              skipped=str(sum(r[1] in ("SKIP", "KNOWN") for r in rows)),
                              time=f"{sum(r[3] for r in rows):.3f}")
        for check, verdict, detail, seconds in rows:
            case = ET.SubElement(suite, "testcase", classname=Path(fmu).stem, name=check,
                                 time=f"{seconds:.3f}")
            if verdict == "FAIL":
                ET.SubElement(case, "failure", message=detail)
            elif verdict in ("SKIP", "KNOWN"):
                ET.SubElement(case, "skipped", message=f"{verdict}: {detail}")
    ET.indent(suites)
    ET.ElementTree(suites).write(file, encoding="utf-8", xml_declaration=True)


def serialized_states(paths, directory):
    """``{path: (GUID, file)}``: a serialized state of each FMI 2.0/3.0 co-simulation FMU of ``paths``
    that can give one (a child probe each), written to ``directory``."""
    out = {}
    for i, path in enumerate(paths):
        try:
            version, root = fmi_version(path)
        except (KeyError, ET.ParseError, OSError, zipfile.BadZipFile):
            continue
        if version.split(".")[0] not in ("2", "3") or root.find("CoSimulation") is None:
            continue
        guid = root.get("guid") or root.get("instantiationToken") or ""
        f = Path(directory) / f"{i}.state"
        code, result, _ = run_probe("serialize", path, f)
        if code == 0 and result is not None and result.get("ok") and f.is_file():
            out[path] = (guid, f)
    return out


def run(paths, junit_file=None, reference=None):
    """Check every FMU in ``paths``; prints the lines, writes the JUnit file; returns the exit code."""
    results = {}
    with tempfile.TemporaryDirectory(prefix="fmucheck_states_") as tmp:
        states = serialized_states(paths, tmp) if len(paths) > 1 else {}
        for path in paths:
            own = states.get(path, (None, None))[0]
            foreign = [(str(other), f) for other, (guid, f) in states.items()
                       if other != path and guid != own]
            rows = results[path] = check_fmu(path, (reference,) if reference else (REFERENCE_DIR,), foreign)
            for check, verdict, detail, _ in rows:
                one_line = " | ".join(part.strip() for part in str(detail).splitlines() if part.strip())
                print(f"{verdict:5s}  {path}  {check}: {one_line}", flush=True)
    if junit_file:
        Path(junit_file).parent.mkdir(parents=True, exist_ok=True)
        junit(results, junit_file)
    return 1 if any(r[1] == "FAIL" for rows in results.values() for r in rows) else 0

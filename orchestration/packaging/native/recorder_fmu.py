"""RowRecorder: a native FMI 2.0 co-simulation FMU that records its inputs as binary rows, for a
compiled engine (libcosim, Ecos) that steps it with the units it observes
(:mod:`orchestration.run.row_recorder`).

Inputs ``x0`` .. ``x63`` (Real), ``k0`` .. ``k7`` (Integer), ``b0`` .. ``b15`` (Boolean); fixed
parameters ``rows_file`` (String: the file the rows go to), ``n_real``, ``n_integer``, ``n_boolean``
(Integer: how many inputs of each type are recorded, the first ones) and ``rows`` (Integer: how
many rows), ``block_rows`` (Integer: rows per write).  At each ``doStep(t, h)`` it takes the row
``t, x0.., k0.., b0..`` of the values the engine set at ``t`` (Integers and Booleans as exact
doubles) and appends them to the file every ``block_rows`` rows, and at the last one.  The C
model and the file format: ``fmu/recorder/native_model.c``.

:func:`build` compiles it (Linux x86_64, host compiler); :func:`recorder_fmu_for` builds it once
into a cache directory keyed by its sources.
"""

from __future__ import annotations

import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import satmotor
import satmotor.interface as itf
from orchestration.packaging.fmu_model_description import COPYRIGHT, LICENSE
from orchestration.packaging.native.compiler import GLUE_DIR, build_native_fmu
from orchestration.packaging.native.fmus import LINUX
from orchestration.packaging.native.tables import model_files

__all__ = ["MODEL_NAME", "N_REAL", "N_INTEGER", "N_BOOLEAN", "BLOCK", "VARIABLES", "VR", "build",
           "recorder_fmu_for", "model_description"]

MODEL_NAME = "RowRecorder"
N_REAL, N_INTEGER, N_BOOLEAN = 64, 8, 16  # RR_REAL, RR_INTEGER, RR_BOOLEAN of the C model
BLOCK = 32768  # RR_BLOCK of the C model: the doubles it holds before a write (block_rows * row width)
SOURCE = GLUE_DIR.parents[1] / "recorder" / "native_model.c"
DATE = "2026-01-01T00:00:00Z"  # fixed: reproducible builds

VARIABLES = (
    tuple(itf.Variable(f"x{j}", "input", "Real", 0.0, "", f"Real input {j}, recorded") for j in range(N_REAL))
    + tuple(itf.Variable(f"k{j}", "input", "Integer", 0, "", f"Integer input {j}, recorded")
            for j in range(N_INTEGER))
    + tuple(itf.Variable(f"b{j}", "input", "Boolean", False, "", f"Boolean input {j}, recorded as 0 / 1")
            for j in range(N_BOOLEAN))
    + (itf.Variable("rows_file", "parameter", "String", "", "", "the file the rows go to (binary doubles)"),
       itf.Variable("n_real", "parameter", "Integer", 0, "", f"Real inputs recorded, x0.. (0 .. {N_REAL})"),
       itf.Variable("n_integer", "parameter", "Integer", 0, "",
                    f"Integer inputs recorded, k0.. (0 .. {N_INTEGER})"),
       itf.Variable("n_boolean", "parameter", "Integer", 0, "",
                    f"Boolean inputs recorded, b0.. (0 .. {N_BOOLEAN})"),
       itf.Variable("rows", "parameter", "Integer", 1, "", "rows to record (>= 1); later steps record none"),
       itf.Variable("block_rows", "parameter", "Integer", 1, "", "rows per write to rows_file (>= 1)")))
VR = {v.name: i for i, v in enumerate(VARIABLES)}  # value reference = position (native_tables)


def model_description():
    """modelDescription.xml (str, guid ``{GUID}``) of the FMI 2.0 RowRecorder."""
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": MODEL_NAME, "guid": "{GUID}",
        "description": "records its inputs as binary rows of doubles (satmotor's compiled-engine recorder)",
        "author": itf.AUTHOR, "version": satmotor.__version__, "copyright": COPYRIGHT, "license": LICENSE,
        "generationTool": "satmotor native C glue", "generationDateAndTime": DATE,
        "variableNamingConvention": "flat"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": MODEL_NAME, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canBeInstantiatedOnlyOncePerProcess": "false",
        "canInterpolateInputs": "false", "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": "false", "canSerializeFMUstate": "false"})
    cats = ET.SubElement(root, "LogCategories")
    ET.SubElement(cats, "Category", {"name": "logStatusError"})
    mv = ET.SubElement(root, "ModelVariables")
    for vr, v in enumerate(VARIABLES):
        attrs = {"name": v.name, "valueReference": str(vr), "description": v.description,
                 "causality": v.causality,
                 "variability": "fixed" if v.causality == "parameter" else
                 ("continuous" if v.type == "Real" else "discrete")}
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        start = (repr(float(v.start)) if v.type == "Real" else str(int(v.start)) if v.type == "Integer"
                 else ("true" if v.start else "false") if v.type == "Boolean" else v.start)
        ET.SubElement(sv, v.type, {"start": start})
    ET.SubElement(root, "ModelStructure")
    ET.indent(root, space="\t")
    text = ET.tostring(root, encoding="UTF-8", xml_declaration=True).decode()
    head = text.index("?>") + 2
    return '<?xml version="1.0" encoding="UTF-8"?>' + text[head:] + "\n"


def sources():
    """The C files of the model besides the glue and the generated ``sm_vars.h`` / ``sm_vars.c``."""
    common = GLUE_DIR.parent / "common"
    return [SOURCE, common / "sm_values.h", common / "sm_values.c"]


def build(out_dir):
    """Write ``<out_dir>/RowRecorder.fmu`` (FMI 2.0, Linux x86_64); returns its path."""
    with tempfile.TemporaryDirectory(prefix="rr_vars_") as tmp:
        files = [*sources(), *model_files(MODEL_NAME, tmp, VARIABLES)]
        out = Path(out_dir) / f"{MODEL_NAME}.fmu"
        path, _ = build_native_fmu(MODEL_NAME, files, model_description(), out, "2.0", LINUX["2.0"])
    return path


def recorder_fmu_for(cache_dir):
    """The RowRecorder FMU, built once into ``cache_dir/<key>/`` and reused while its C sources and
    this module are unchanged (the key: a SHA-256 over them); a build is a C compile (about a
    second)."""
    from orchestration.packaging.native.compiler import build_once

    return build_once(cache_dir, f"{MODEL_NAME}.fmu", [*sources(), Path(__file__)], build)

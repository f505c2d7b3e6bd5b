"""Recording inside a compiled engine: the RowRecorder FMU
(:mod:`orchestration.packaging.native.recorder_fmu`)
added to the system the engine loads, connected to the outputs a run records, and the master's rows
made from the binary rows it writes.

Why.  libcosim and Ecos step the units in C++; what costs is getting the values out: one Python
call per variable and step (Ecos's ``get_real``, libcosim's last-value observer), or libcosim's
time-series observer, which keeps a ``std::map`` node per variable and step and copies its time
index at every read.  An FMU connected like any other unit gets the values by the engine's own
transfers, in C++, and hands them over as blocks of exact doubles.

Rows.  Under a fixed-step (Jacobi) engine the recorder's ``doStep`` from ``t_r`` sees the values
transferred at ``t_r``: the plant's outputs and the profiles at ``t_r``, and the controller's
outputs of its last completed step.  The controller sample of ``t_j`` (``j`` a multiple of
``N = controller_every``) completes at ``t_j + Ts`` and reaches the recorder's row ``j + N``.  The
master's row ``k`` holds the plant and profiles at ``t_k`` and the controller's sample of
``t_j``, ``j = N floor(k / N)``: :meth:`Rows.table` takes them from recorder rows ``k`` and
``N (floor(k / N) + 1)``.  So the engine runs ``N (floor(n / N) + 1) + 1`` base steps for ``n``
steps of the scenario (:func:`steps_needed`), and the time column is ``k h`` as the master's.

Columns.  :func:`columns_for` gives what a run records: at level ``metrics`` only the columns the
metrics read (:mod:`orchestration.results.running`), else every output and profile as the master.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from orchestration.packaging.native import recorder_fmu
from orchestration.packaging.ssd import NS, OSP_NS, OSP_TYPE, SSC_NS, SSD_NS, SSV_NS, seconds_text
from orchestration.results.running import FLAG_COLUMNS, METRIC_COLUMNS, PHASE_COLUMN, PSI_SET_COLUMN
from orchestration.results.writer import level
from orchestration.scenario.recording import recorded_columns
from orchestration.scenario.system import CONTROLLER, PLANT, PROFILE

__all__ = ["NS", "UNIT", "ROWS_FILE", "columns_for", "max_block_rows", "add_to_ssd", "steps_needed", "Rows"]

UNIT = "recorder"  # the component's name in the system
ROWS_FILE = "rows.bin"
_TYPE_INPUT = {"Real": "x", "Integer": "k", "Boolean": "b"}


def columns_for(scenario, outputs, signals_unit):
    """``(columns, sources)``: the row's column names as the master names them (``time`` first) and,
    per column after ``time``, ``(component, variable, type)`` of the output it records.
    ``outputs``: ``{component: [(name, type)]}`` of the plant, the controller and the signals FMU
    (``signals_unit``) in model-description order; types ``Real``, ``Integer``, ``Boolean``."""
    profiles = sorted(scenario.profiles)
    columns = recorded_columns([n for n, _ in outputs[PLANT]], [n for n, _ in outputs[CONTROLLER]], profiles)
    if level(scenario) == "metrics":  # no time series kept
        wanted = {*METRIC_COLUMNS.values(), *FLAG_COLUMNS.values(), PHASE_COLUMN, PSI_SET_COLUMN}
        columns = [c for c in columns if c == "time" or c in wanted]
    types = {f"{u}.{n}": t for u in (PLANT, CONTROLLER) for n, t in outputs[u]}
    types.update({f"{PROFILE}.{n}": t for n, t in outputs[signals_unit]})
    sources = []
    for c in columns[1:]:
        unit, name = c.split(".", 1)
        sources.append((signals_unit if unit == PROFILE else unit, name, types[c]))
    return columns, sources


def steps_needed(scenario):
    """Base steps the engine runs for ``scenario``: up to the controller sample after the last row's,
    and one more for the recorder to take that row."""
    n, N = round(scenario.stop_time / scenario.step), scenario.controller_every
    return N * (n // N + 1) + 1


def _inputs(sources):
    """``[(source component, variable, recorder input)]`` and the counts per type."""
    count = dict.fromkeys(_TYPE_INPUT, 0)
    out = []
    for unit, name, vtype in sources:
        out.append((unit, name, f"{_TYPE_INPUT[vtype]}{count[vtype]}"))
        count[vtype] += 1
    limits = {"Real": recorder_fmu.N_REAL, "Integer": recorder_fmu.N_INTEGER,
              "Boolean": recorder_fmu.N_BOOLEAN}
    for vtype, n in count.items():
        if n > limits[vtype]:
            raise ValueError(f"{n} {vtype} outputs to record: the RowRecorder FMU has {limits[vtype]} inputs")
    return out, count


def max_block_rows(sources):
    """The most rows the RowRecorder holds before a write, recording ``sources``."""
    return recorder_fmu.BLOCK // (1 + len(sources))


def _q(ns, tag):
    return f"{{{ns}}}{tag}"


def add_to_ssd(ssd_bytes, scenario, sources, recorder_source, rows_file, block_rows):
    """The system description ``ssd_bytes`` (of :func:`orchestration.packaging.ssd.ssd_xml`) with the
    RowRecorder as component :data:`UNIT` (FMU ``recorder_source``, step hint ``h``), connected to
    ``sources`` (of :func:`columns_for`), writing ``rows_file`` every ``block_rows`` rows;
    returns bytes."""
    inputs, count = _inputs(sources)
    el = ET.Element(_q(SSD_NS, "Component"), {
        "name": UNIT, "type": "application/x-fmu-sharedlibrary", "source": recorder_source})
    cons = ET.SubElement(el, _q(SSD_NS, "Connectors"))
    for _, _, inp in inputs:
        con = ET.SubElement(cons, _q(SSD_NS, "Connector"), {"name": inp, "kind": "input"})
        ET.SubElement(con, _q(SSC_NS, {"x": "Real", "k": "Integer", "b": "Boolean"}[inp[0]]))
    values = {"rows_file": ("String", str(rows_file)), "n_real": ("Integer", count["Real"]),
              "n_integer": ("Integer", count["Integer"]), "n_boolean": ("Integer", count["Boolean"]),
              "rows": ("Integer", steps_needed(scenario)), "block_rows": ("Integer", block_rows)}
    pv = ET.SubElement(ET.SubElement(ET.SubElement(el, _q(SSD_NS, "ParameterBindings")),
                                     _q(SSD_NS, "ParameterBinding")), _q(SSD_NS, "ParameterValues"))
    ps = ET.SubElement(pv, _q(SSV_NS, "ParameterSet"), {"version": "1.0", "name": f"{scenario.name}.{UNIT}"})
    params = ET.SubElement(ps, _q(SSV_NS, "Parameters"))
    for name, (vtype, value) in values.items():
        p = ET.SubElement(params, _q(SSV_NS, "Parameter"), {"name": name})
        ET.SubElement(p, _q(SSV_NS, vtype), {"value": str(value)})
    anns = ET.SubElement(el, _q(SSD_NS, "Annotations"))
    ann = ET.SubElement(anns, _q(SSC_NS, "Annotation"), {"type": OSP_TYPE})
    ET.SubElement(ann, _q(OSP_NS, "StepSizeHint"), {"value": seconds_text(scenario.step)})
    links = [ET.Element(_q(SSD_NS, "Connection"), {"startElement": unit, "startConnector": name,
                                                     "endElement": UNIT, "endConnector": inp})
             for unit, name, inp in inputs]
    # inserted as text before the ends of Elements and Connections (the prefixes ssd_xml writes): a
    # parse and a new serialization of the whole description would cost more than the rest
    out = ssd_bytes
    for end, items in ((b"</ssd:Elements>", [el]), (b"</ssd:Connections>", links)):
        at = out.rindex(end)
        text = b"".join(_fragment(x) for x in items)
        out = out[:at] + text + out[at:]
    return out


def _fragment(element):
    """``element`` as XML text with the prefixes of :mod:`orchestration.packaging.ssd` (registered
    there), without namespace declarations (the description's root has them)."""
    ET.indent(element, space="  ")
    text = ET.tostring(element, encoding="unicode")
    return re.sub(r' xmlns:\w+="[^"]*"', "", text).encode() + b"\n"


class Rows:
    """The RowRecorder's file read as it grows, and the master's rows made from it.

    ``sources``: of :func:`columns_for`; the recorder row is ``t``, the Real sources, the Integer
    ones, the Boolean ones (each in ``sources`` order); :meth:`table` gives the master's row layout
    (``time`` and ``sources`` order)."""

    def __init__(self, path, scenario, sources):
        self.path, self.h, self.N = Path(path), scenario.step, scenario.controller_every
        self.n = round(scenario.stop_time / scenario.step)
        self.every = max(1, round(scenario.record.interval / scenario.step)) if scenario.record else 1
        inputs, count = _inputs(sources)
        offset = {"x": 1, "k": 1 + count["Real"], "b": 1 + count["Real"] + count["Integer"]}
        self.width = 1 + sum(count.values())
        self.index = np.array([offset[inp[0]] + int(inp[1:]) for _, _, inp in inputs], dtype=np.intp)
        from_controller = np.array([u == CONTROLLER for u, _, _ in sources], dtype=bool)
        self._plant_cols, self._ctrl_cols = np.flatnonzero(~from_controller), np.flatnonzero(from_controller)
        self._pos = 0  # bytes read
        self._rows = np.empty((0, self.width))  # recorder rows read and not yet used, from row self._first
        self._first = 0
        self.next_row = 0  # the master's next row

    def _read(self):
        with open(self.path, "rb") as f:
            f.seek(self._pos)
            data = f.read()
        usable = len(data) // (8 * self.width) * 8 * self.width
        self._pos += usable
        if usable:
            new = np.frombuffer(data, dtype=np.float64, count=usable // 8).reshape(-1, self.width)
            self._rows = np.concatenate([self._rows, new]) if len(self._rows) else new

    def table(self):
        """The master's rows ``next_row..`` whose recorder rows are on disk (every ``every``-th, as
        the master records), as a float64 array; ``np.empty((0, columns))`` when none."""
        self._read()
        have = self._first + len(self._rows)  # recorder rows 0 .. have - 1 on disk
        N = self.N
        last = min(self.n, (have - 1) // N * N - 1)  # the controller row N (k // N + 1) <= have - 1
        ks = np.arange(self.next_row, last + 1)
        ks = ks[ks % self.every == 0]
        if len(ks) == 0:
            self.next_row = max(self.next_row, last + 1)
            return np.empty((0, 1 + len(self.index)))
        plant_rows = ks - self._first
        ctrl_rows = N * (ks // N + 1) - self._first
        r = self._rows
        for k, row in ((ks[0], plant_rows[0]), (ks[-1], plant_rows[-1])):  # the engine's time of the rows
            if abs(r[row, 0] - k * self.h) > 1e-6 * self.h:
                raise RuntimeError(f"the recorder's rows are not at the steps expected: row {int(k)} at t = "
                                   f"{r[row, 0]!r} s, expected {k * self.h!r} s")
        out = np.empty((len(ks), 1 + len(self.index)))
        out[:, 0] = ks * self.h
        pc, cc = self._plant_cols, self._ctrl_cols
        out[:, 1 + pc] = r[np.ix_(plant_rows, self.index[pc])]
        out[:, 1 + cc] = r[np.ix_(ctrl_rows, self.index[cc])]
        self.next_row = last + 1
        drop = min(len(r), self.next_row - self._first)  # the rows of later ones are at next_row or after
        if drop > 0:
            self._rows, self._first = r[drop:], self._first + drop
        return out

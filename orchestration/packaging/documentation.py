"""``documentation/index.html`` of an FMU: its variables from the interface tables, its capability
flags, and the equations from the docstrings of the modules it runs (pythonfmu and native alike)."""

from __future__ import annotations

import ast
import html
import importlib
import inspect

from orchestration.packaging.fmu_model_description import output_initial_calculated
from orchestration.packaging.sources import COMMON_OPTIONS, FMUS

__all__ = ["documentation"]


def documentation(name, flags=None, intro=None):
    """index.html from the same interface tables the slave registers, and the model docstrings.
    ``flags``: the capability flags to list (default: the pythonfmu FMU's); ``intro``: the opening
    paragraph (default: the slave script's docstring).  The native FMUs pass theirs."""
    import satmotor.interface as itf

    script, tables, modules, options = FMUS[name]
    intro = intro if intro is not None else ast.get_docstring(ast.parse(script.read_text())) or ""
    rows = []
    for table in tables:
        for v in getattr(itf, table):
            start = str(v.start).lower() if isinstance(v.start, bool) else v.start  # as in the XML
            if v.causality == "output" and output_initial_calculated(name):
                start = "calculated"  # from the parameters at initialization (no start in the XML)
            rows.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in (
                v.name, v.causality, v.type, start, v.unit, v.description)) + "</tr>")
    flags = flags if flags is not None else {**COMMON_OPTIONS, **options}
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{name}</title></head><body>",
             f"<h1>{name}</h1><p>{html.escape(intro)}</p>",
             "<h2>Variables</h2><table border='1'><tr><th>name</th><th>causality</th><th>type</th>"
             "<th>start</th><th>unit</th><th>description</th></tr>", *rows, "</table>",
             "<h2>Capability flags</h2><ul>",
             *(f"<li>{k} = {str(v).lower()}</li>" for k, v in flags.items()), "</ul>",
             "<h2>Equations</h2>"]
    for mod in modules:
        doc = inspect.getdoc(importlib.import_module(mod)) or ""
        parts.append(f"<h3>{mod}</h3><pre>{html.escape(doc)}</pre>")
    parts.append("</body></html>")
    return "\n".join(parts)

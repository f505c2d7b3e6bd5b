"""No dependency circles: the include graph of the C core (``fmu/native/core``: a unit is ``sm_x.c`` with
``sm_x.h``) and the import graph of ``orchestration``'s sub-packages (and of its modules) have no cycle;
the sub-packages' imports point the way ``orchestration/__init__.py`` lists them (top to bottom); the
metrics depend on neither the drive nor the machine."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "fmu" / "native" / "core"
ORCHESTRATION = ROOT / "orchestration"
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def find_cycle(graph):
    """A cycle of ``graph`` ({node: set of nodes}) as a list ``[a, b, ..., a]``, or None."""
    state = {}  # 1 on the path, 2 done

    def visit(n, path):
        state[n] = 1
        path.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return path[path.index(m):] + [m]
            if m not in state and (c := visit(m, path)):
                return c
        path.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state and (c := visit(n, [])):
            return c
    return None


def include_graph(core=CORE, unit=True):
    """``{unit: units it includes}`` of the C core's quoted includes that name core files (the generated
    ``sm_params.h`` is not one); ``unit`` False: file by file."""
    files = {p.name: p for p in sorted(core.glob("*.[ch]"))}
    key = (lambda name: name.rsplit(".", 1)[0]) if unit else (lambda name: name)
    graph = {}
    for name, p in files.items():
        deps = graph.setdefault(key(name), set())
        deps.update(key(h) for h in INCLUDE.findall(p.read_text()) if h in files and key(h) != key(name))
    return graph


def module_name(path, root=ORCHESTRATION):
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path, known, root=ORCHESTRATION):
    """The modules of ``known`` (names of ``root``'s modules) that ``path`` imports, at any depth of the file
    (lazy imports too): ``from package import module`` imports the module, ``from module import name``
    the module."""
    here = module_name(path, root)
    package = here if path.name == "__init__.py" else here.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the package
                parts = package.split(".")
                parts = parts[: len(parts) - node.level + 1]
                mod = ".".join([*parts, node.module] if node.module else parts)
            else:
                mod = node.module or ""
            out.update(f"{mod}.{a.name}" if f"{mod}.{a.name}" in known else mod for a in node.names)
    return out & known


def sub_package(module, root=ORCHESTRATION):
    """The sub-package (a folder of ``root``) ``module`` is in, or None (``orchestration``,
    ``orchestration.__main__``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and (root / parts[1] / "__init__.py").is_file() else None


def import_graphs(root=ORCHESTRATION):
    """``(modules, sub_packages)``: ``{module: modules it imports}`` of the package's own modules, and
    ``{sub-package: sub-packages it imports}``."""
    files = sorted(root.rglob("*.py"))
    known = {module_name(p, root) for p in files}
    modules, subs = {}, {}
    for p in files:
        me = module_name(p, root)
        deps = imported_modules(p, known, root) - {me}
        modules[me] = deps
        if (sub := sub_package(me, root)) is not None:
            theirs = {sub_package(d, root) for d in deps}
            subs.setdefault(sub, set()).update(theirs - {None, sub})
    return modules, subs


def documented_order(root=ORCHESTRATION):
    """The sub-packages in the order ``orchestration/__init__.py``'s docstring lists them."""
    doc = ast.get_docstring(ast.parse((root / "__init__.py").read_text())) or ""
    return re.findall(r"^\* :mod:`orchestration\.(\w+)`", doc, re.MULTILINE)


def test_the_cycle_finder_finds_a_cycle_and_accepts_a_tree():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"a"}}) == ["a", "a"]


def test_the_include_graph_sees_a_cycle_between_two_units(tmp_path):
    (tmp_path / "sm_a.h").write_text('#include "sm_b.h"\n')
    (tmp_path / "sm_a.c").write_text('#include "sm_a.h"\n#include "sm_params.h"\n')
    (tmp_path / "sm_b.h").write_text("\n")
    (tmp_path / "sm_b.c").write_text('#include "sm_b.h"\n #  include "sm_a.h"\n')
    assert include_graph(tmp_path) == {"sm_a": {"sm_b"}, "sm_b": {"sm_a"}}
    assert find_cycle(include_graph(tmp_path)) is not None
    assert find_cycle(include_graph(tmp_path, unit=False)) is None  # file by file no cycle: units see it


def test_the_import_graph_sees_relative_lazy_and_from_package_imports(tmp_path):
    root = tmp_path / "orchestration"
    for d in ("a", "b"):
        (root / d).mkdir(parents=True)
        (root / d / "__init__.py").write_text("")
    (root / "__init__.py").write_text("")
    (root / "a" / "x.py").write_text("def f():\n    from orchestration.b import y\n")
    (root / "b" / "y.py").write_text("from ..a import x\nfrom . import z\n")
    (root / "b" / "z.py").write_text("")
    modules, subs = import_graphs(root)
    assert modules["orchestration.a.x"] == {"orchestration.b.y"}
    assert modules["orchestration.b.y"] == {"orchestration.a.x", "orchestration.b.z"}
    assert subs == {"a": {"b"}, "b": {"a"}}
    assert find_cycle(subs) is not None


def test_the_c_core_has_no_include_cycle_unit_by_unit_or_file_by_file():
    units = include_graph()
    new = {"sm_inverter", "sm_pwm_link", "sm_phases", "sm_curves", "sm_common", "sm_table_file"}
    assert new <= set(units)
    assert find_cycle(units) is None, f"include cycle between the core's units: {find_cycle(units)}"
    files = include_graph(unit=False)
    assert find_cycle(files) is None, f"include cycle between the core's files: {find_cycle(files)}"


def test_orchestration_has_no_import_cycle_between_sub_packages_or_modules():
    modules, subs = import_graphs()
    assert {"run", "results", "scenario", "process"} <= set(subs)
    assert find_cycle(subs) is None, f"import cycle between orchestration's sub-packages: {find_cycle(subs)}"
    assert find_cycle(modules) is None, f"import cycle between orchestration's modules: {find_cycle(modules)}"


def test_the_sub_packages_import_only_those_listed_below_them_in_the_package_docstring():
    _, subs = import_graphs()
    order = documented_order()
    assert sorted(order) == sorted(subs), "orchestration/__init__.py lists every sub-package once"
    upward = [(a, b) for a in subs for b in subs[a] if order.index(b) < order.index(a)]
    assert not upward, f"imports against the documented order (importer, imported): {upward}"



def test_the_metrics_import_nothing_of_the_drive_or_the_machine():
    code = ("import sys, satmotor.metrics; "
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('satmotor'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert set(out.stdout.split()) == {"satmotor", "satmotor.metrics", "satmotor.drive_phase"}


def test_the_drive_and_the_metrics_share_the_phases():
    from satmotor import drive_phase, metrics
    from satmotor.control import drive

    assert (drive.PREMAG, drive.RUN) == (drive_phase.PREMAG, drive_phase.RUN) == (0, 1)
    assert metrics.RUN is drive_phase.RUN

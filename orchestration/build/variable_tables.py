"""The README's variable tables, generated from the interface tables of :mod:`satmotor.interface`.

``python -m orchestration.build.variable_tables`` prints the Markdown; ``--write README.md`` replaces the
text between the ``<!-- variables:begin -->`` and ``<!-- variables:end -->`` markers in place.
``tests/test_docs.py`` checks that the README holds exactly what this module generates, so a
variable added to the FMUs cannot be missing from the README.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from satmotor.interface import (
    CONTROLLER_INPUTS,
    CONTROLLER_OUTPUTS,
    CONTROLLER_PARAMETERS,
    MOTOR_PARAMETERS,
    PLANT_INPUTS,
    PLANT_OUTPUTS,
    PLANT_PARAMETERS,
)

BEGIN, END = "<!-- variables:begin -->", "<!-- variables:end -->"


def _start(var):
    if var.type == "String":
        return f"`{var.start}`" if var.start else "(empty)"
    if var.type == "Boolean":
        return "true" if var.start else "false"
    return f"{var.start:g}" if isinstance(var.start, float) else str(var.start)


def _table(variables):
    rows = ["| name | type | unit | start | description |", "|---|---|---|---|---|"]
    for v in variables:
        desc = v.description.replace("|", "\\|")
        rows.append(f"| `{v.name}` | {v.type} | {v.unit or '-'} | {_start(v)} | {desc} |")
    return "\n".join(rows)


def markdown():
    """The Markdown of both units' variables (without the markers)."""
    motor = {v.name for v in MOTOR_PARAMETERS}
    own = [v for v in CONTROLLER_PARAMETERS if v.name not in motor]
    parts = [
        "Generated from `satmotor/interface.py` by `python -m orchestration.build.variable_tables --write "
        "README.md`; the same table is in each pythonfmu FMU's `documentation/index.html`. Both "
        "variants (pythonfmu, native FMI 2.0 and 3.0) have these names and start values.",
        "### `SaturatedInductionMotor` (the plant)",
        "Inputs:", _table(PLANT_INPUTS),
        "Outputs (none with direct feedthrough):", _table(PLANT_OUTPUTS),
        "Parameters:", _table(PLANT_PARAMETERS),
        "### `BacksteppingController`",
        "Inputs:", _table(CONTROLLER_INPUTS),
        "Outputs (computed at a sample, held until the next):", _table(CONTROLLER_OUTPUTS),
        "Parameters (and the motor parameters of the plant's table, under the same names and "
        "defaults: the controller's model of the motor):", _table(own),
    ]
    return "\n\n".join(parts)


def replace_block(text):
    """``text`` with the block between the markers replaced by :func:`markdown`."""
    i, j = text.find(BEGIN), text.find(END)
    if i < 0 or j < i:
        raise ValueError(f"the markers {BEGIN} ... {END} are missing")
    return text[: i + len(BEGIN)] + "\n" + markdown() + "\n" + text[j:]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--write", type=Path, metavar="FILE", help="replace the block between the markers")
    a = p.parse_args(argv)
    if a.write is None:
        print(markdown())
        return 0
    a.write.write_text(replace_block(a.write.read_text(encoding="utf-8")), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

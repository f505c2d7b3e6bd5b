"""The page ``docs/variables.md``, generated from the interface tables of :mod:`satmotor.interface`.

``python -m orchestration.packaging.variable_tables`` prints the page; ``--write docs/variables.md`` writes
it.
``tests/test_docs.py`` checks that the committed page is exactly what this module generates, so a
variable added to the FMUs cannot be missing from the documentation.
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

#: where the page lives, relative to the repository root
PAGE = "docs/variables.md"


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
    """The Markdown tables of both units' variables, under a heading of each unit."""
    motor = {v.name for v in MOTOR_PARAMETERS}
    own = [v for v in CONTROLLER_PARAMETERS if v.name not in motor]
    parts = [
        "## `SaturatedInductionMotor` (the plant)",
        "Inputs:", _table(PLANT_INPUTS),
        "Outputs (none with direct feedthrough):", _table(PLANT_OUTPUTS),
        "Parameters:", _table(PLANT_PARAMETERS),
        "## `BacksteppingController`",
        "Inputs:", _table(CONTROLLER_INPUTS),
        "Outputs (computed at a sample, held until the next):", _table(CONTROLLER_OUTPUTS),
        "Parameters (and the motor parameters of the plant's table, under the same names and "
        "defaults: the controller's model of the motor):", _table(own),
    ]
    return "\n\n".join(parts)


def page():
    """The whole text of ``docs/variables.md``."""
    head = [
        "# The FMUs' variables",
        "<!-- Generated: do not edit. Run `python -m orchestration.packaging.variable_tables --write "
        f"{PAGE}` after a change to `satmotor/interface.py`. -->",
        "Every variable of the two FMUs, from the tables in `satmotor/interface.py`, the single source the "
        "FMUs are built from. The same tables are in each FMU's `documentation/index.html`. The pythonfmu "
        "FMUs and the native ones (FMI 2.0 and 3.0) have these names, value references and start values; "
        "FMI 3.0 adds the independent variable `time`. How to wire them, step them and start them: "
        "[hosts.md](hosts.md).",
        "In the descriptions, \"the seed\" is the paper this project implements: Ouadi, Giri and Ikhouane, "
        "*Backstepping control of saturated induction motors* (\"the seed's law\": its control law, "
        "without the integral action we added; \"H1\" and the equation numbers are the paper's).",
    ]
    return "\n\n".join(head) + "\n\n" + markdown() + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--write", type=Path, metavar="FILE", help=f"write the page to FILE ({PAGE})")
    a = p.parse_args(argv)
    if a.write is None:
        print(page(), end="")
        return 0
    a.write.write_text(page(), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""A study's files once its variants have run, written by ``batch`` for every sweep into
``OUT/<sweep name>/``:

* ``sweep.csv``, ``sweep.parquet``, ``sweep.png`` (:mod:`orchestration.results.sweep_table`);
* ``study_summary.csv`` (:mod:`orchestration.study.summary`): per metric its distribution and the
  fraction outside the acceptance bounds with its confidence interval, the variants that failed,
  missed a bound or did not hold their set-points, each by name and parameters;
* for ``analysis: sobol | morris``, ``sensitivity.csv`` (:mod:`orchestration.study.analyses`) and
  ``sensitivity.png`` (:mod:`orchestration.study.figures`);
* ``report.html``: one self-contained page (the figures embedded as base64 PNG, no other file or
  network access) with the tables, the scenario file as written, the versions, and what failed and
  why.

:func:`write_study` also returns the lines the batch prints: each bound's share of variants outside
it, and each variant outside, failed or not held, named with its parameters.
"""

from __future__ import annotations

import base64
import html
import math
import platform
import sys
from datetime import datetime, timezone
from pathlib import Path

from orchestration.results import atomic

__all__ = ["FILES", "write_study", "report_html"]

FILES = ("study_summary.csv", "sensitivity.csv", "sensitivity.png", "report.html")
PACKAGES = ("satmotor", "numpy", "pandas", "fmpy", "SALib", "matplotlib", "PyYAML")
MAX_ROWS = 500  # variants shown in the report's table (every one is in sweep.csv)


def _write_csv(df, path):
    with atomic.atomic_file(path, "wb") as f:
        df.to_csv(f, index=False)


def write_study(sweep, rows, directory, plot=True, file=None):
    """Write every file of the study of ``sweep`` (the batch's ``rows``, the variants' results in
    ``directory``; ``plot`` False: no figure); returns ``(paths written, lines to print)``."""
    from orchestration.results.sweep_table import sweep_frame, write_sweep
    from orchestration.study.summary import summary_frame

    d = Path(directory)
    paths = write_sweep(sweep, rows, d, plot, file)
    df = sweep_frame(sweep, rows, d, file)
    summary = summary_frame(sweep, df, d)
    _write_csv(summary, d / FILES[0])
    paths.append(d / FILES[0])
    sensitivity = None
    for stale in FILES[1:]:
        (d / stale).unlink(missing_ok=True)
    if sweep.design is not None:
        from orchestration.study.analyses import indices
        from orchestration.study.figures import sensitivity_figure

        sensitivity = indices(sweep, df)
        _write_csv(sensitivity, d / FILES[1])
        paths.append(d / FILES[1])
        title = (f"{d.name}: {sweep.kind} indices of {len(sweep.variants)} variants "
                 f"({sweep.design['samples']} base samples, seed {sweep.seed})")
        if plot and sensitivity_figure(sensitivity, sweep.kind, title, d / FILES[2]):
            paths.append(d / FILES[2])
    page = report_html(sweep, df, summary, sensitivity, d, file)
    with atomic.atomic_file(d / FILES[3], "w") as f:
        f.write(page)
    paths.append(d / FILES[3])
    return paths, screen_lines(d.name, summary)


def screen_lines(name, summary):
    """What the batch says of a study: each bound's share of variants outside it, and the variants
    that failed, did not hold their set-points or missed a bound, by name and parameters (and the
    bounds they missed)."""
    lines = []
    for _, r in summary.iterrows():
        if not isinstance(r["outside_variants"], str) or not r["outside"]:
            continue
        what = f"{r['metric']} <= {r['bound']:.4g}" if isinstance(r["bound"], float) and math.isfinite(
            r["bound"]) else r["metric"]
        lines.append(f"sweep {name}: {what}: {int(r['outside'])} of {_total(r)} variants outside "
                     f"({r['outside_fraction']:.1%}, 95 % interval {r['outside_low']:.1%} .. "
                     f"{r['outside_high']:.1%})")
        if r["metric"].startswith("("):  # the runs' rows name every variant; a bound's row its share
            lines += [f"  {v}" for v in r["outside_variants"].split("; ")]
    return lines


def _total(r):
    return round(r["outside"] / r["outside_fraction"]) if r["outside_fraction"] else 0


def _by_variant(summary):
    """``{variant name: (label, [what went wrong])}`` from the summary's rows on the runs: a variant
    that failed, missed a bound or did not hold its set-points, once, with every reason."""
    out = {}
    for _, r in summary.iterrows():
        runs = r["metric"] in ("(failed)", "(not accepted)", "(not held)")
        if not (runs and isinstance(r["outside_variants"], str) and r["outside_variants"]):
            continue
        for entry in r["outside_variants"].split("; "):
            label, _, why = entry.partition("): ")
            label = label if label.endswith(")") or not why else label + ")"
            name = label.split(" ", 1)[0]
            said = {"(failed)": why or "failed", "(not held)": "set-points not held",
                    "(not accepted)": f"missed {why}" if why else "missed a bound"}[r["metric"]]
            out.setdefault(name, (label, []))[1].append(said)
    return out


def _image(path, caption, ident):
    if not Path(path).is_file():
        return f'<p id="{ident}-missing">({html.escape(caption)}: not drawn)</p>'
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (f'<figure id="{ident}"><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def _table(df, ident):
    return df.to_html(index=False, table_id=ident, na_rep="", float_format=lambda v: f"{v:.4g}", border=0)


def versions():
    """``{package: version}`` of what made the study, and the Python and the platform."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for p in PACKAGES:
        try:
            out[p] = version(p)
        except PackageNotFoundError:
            out[p] = "not installed"
    return out


STYLE = ("body{font-family:sans-serif;margin:1.5em;max-width:80em}table{border-collapse:collapse;"
         "font-size:0.8em;margin:0.5em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
         "th{background:#eee}pre{background:#f6f6f6;padding:0.6em;font-size:0.8em;overflow:auto}"
         "img{max-width:100%}.bad{color:#b00}")


def report_html(sweep, df, summary, sensitivity, directory, file=None):
    """The page of the study (a string): self-contained HTML, nothing fetched."""
    d = Path(directory)
    name = d.name
    problems = _by_variant(summary)
    try:
        scenario = Path(file).read_text(encoding="utf-8") if file else ""
    except OSError as exc:
        scenario = f"(cannot read {file}: {exc})"
    kind = {"grid": "a grid", "montecarlo": "a Monte Carlo study", "sobol": "a Sobol' sensitivity study",
            "morris": "a Morris screening"}[sweep.kind]
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(name)}: "
             f"study report</title><style>{STYLE}</style></head><body>",
             f"<h1>{html.escape(name)}</h1><p>{kind} of {len(df)} variants over "
             f"{html.escape(', '.join(sweep.parameters))}"
             + (f", seed {sweep.seed}" if sweep.seed is not None else "")
             + f"; written {datetime.now(timezone.utc):%Y-%m-%d %H:%M UTC} from "
             f"<code>{html.escape(str(file or ''))}</code>.</p>",
             "<h2>What failed and why</h2>"]
    if problems:
        parts.append(f"<p>{len(problems)} of {len(df)} variants:</p><ul id='failures'>" + "".join(
            f"<li class='bad'>{html.escape(label)}: <b>{html.escape('; '.join(why))}</b></li>"
            for label, why in problems.values()) + "</ul>")
    else:
        parts.append("<p id='failures'>Every variant ran, held its set-points and met its bounds.</p>")
    parts += ["<h2>The metrics' distributions</h2>",
              _table(summary.drop(columns=["outside_variants"]), "summary"),
              _image(d / "sweep.png", "each metric over the variants (sweep.png)", "sweep-figure")]
    if sensitivity is not None:
        parts += [f"<h2>Sensitivity indices ({sweep.kind})</h2>", _table(sensitivity, "sensitivity"),
                  _image(d / "sensitivity.png", "the indices per metric (sensitivity.png)",
                         "sensitivity-figure")]
    shown = df.head(MAX_ROWS)
    parts += [f"<h2>The variants</h2><p>{len(shown)} of {len(df)} (all in sweep.csv).</p>",
              _table(shown, "variants"), "<h2>The scenario</h2>",
              f"<pre id='scenario'>{html.escape(scenario)}</pre>", "<h2>Versions</h2>",
              "<table id='versions'>" + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>"
                                                for k, v in versions().items()) + "</table>",
              "</body></html>\n"]
    return "\n".join(parts)

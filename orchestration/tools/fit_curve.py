"""``satmotor-cosim fit-curve NOLOAD.csv --R-s OHM (--l-s H | --locked-rotor V,I,P,F) [--out DIR]``:
the magnetizing curve from a no-load test.

Input: a CSV file with a header line and one row per voltage level of a no-load test (star
connection, motor uncoupled): ``V_ll_rms`` [V] line-to-line rms voltage, ``I_rms`` [A] line rms
current, ``f`` [Hz] supply frequency, optionally ``P_in`` [W] input power.  Lines starting with
``#`` and blank lines are skipped.  ``--R-s`` [Ohm] and ``--l-s`` [H] are the stator resistance and
leakage inductance (finite, >= 0), from a DC and a locked-rotor test.

The rows become magnetizing points by :func:`satmotor.identify.noload.magnetizing_points` (the corrections
are listed in its module docstring); every family is fitted by :mod:`satmotor.identify.curve_fit`.  Written
into ``--out`` (default ``results/fit_curve``):

* ``fit.yaml``: ``plant:`` and ``controller:`` overrides of the chosen curve, to paste into a
  scenario, plus ``chosen``, ``fits`` (every family's parameters and residuals) and ``input``;
* ``curve_table.csv``: the points ``i_mu, psi_m`` for ``curve: table`` (made strictly increasing,
  see :func:`satmotor.identify.curve_fit.monotone_table`);
* ``fit.png``: the points, every fit, the residuals, and the chosen fit's 1-sigma band;
* with ``--motor-yaml FILE``: a ready ``motor:`` section (the chosen curve, ``R_s``, ``l_s``, and
  ``l_r``, ``R_r``, ``n_p``, ``J``, ``B`` when given as options; the others keep the default motor's
  values, which a comment lists) and the core-loss resistance ``R_fe`` as the plant needs it (across
  ``v_s - R_s i_s``: :func:`satmotor.identify.noload.plant_core_loss_resistance`; plant only, in the
  ``motor:`` section like the rest), to paste into a scenario.

With ``--locked-rotor V_ll_rms,I_rms,P_in,f`` (and ``--leakage-ratio`` l_r/l_s, default 1) instead of
``--l-s``: the stator leakage, rotor leakage and rotor resistance come from that test and the no-load
fit together (:mod:`satmotor.identify.locked_rotor`), into ``fit.yaml`` (``locked_rotor``) and
``--motor-yaml``.

With ``P_in``: a row whose ``P_in`` is below the stator copper loss by less than ``--copper-tol``
(relative, default 5 %) is taken as lossless, with a warning naming its line; further below it is
refused.  The no-load loss ``P_in - 3 R_s I_rms^2`` is split into core loss (``R_fe``) and friction
(:func:`satmotor.identify.noload.separate_losses`), in ``fit.yaml`` under ``core_loss``.

``--rel-sigma V,I,F,P`` (default 1 % each): the relative standard uncertainty of the columns.  The
fits weight each point by its uncertainty carried from the readings (errors in both i_mu and psi_m,
:mod:`satmotor.identify.uncertainty`); ``fit.yaml`` gives each family's chi-square and, under
``uncertainty``, the chosen curve's 1-sigma relative uncertainty over the measured current range,
the families the data cannot tell from it (``rivals``, with their largest difference), and the
curve's parameters with their 1-sigma values and covariance (``family``, ``parameters: {NAME: {value,
sigma}}``, ``covariance: {parameters, matrix}``): the prior a sweep takes with ``{from: fit.yaml}``.

Exit codes: 0 written; 2 an input problem (the message names the file, the line and the value) or
``--out`` cannot be written.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np

REQUIRED = ("V_ll_rms", "I_rms", "f")
OPTIONAL = ("P_in",)
DEFAULT_OUT = "results/fit_curve"


class InputError(ValueError):
    """A bad no-load file or option; the message names the file, the line and the value."""


def read_noload(path):
    """``(columns, lines)`` of the no-load CSV ``path``: ``columns`` maps each present column name to
    a float array, ``lines`` the file line number (1-based) of each data row.  Raises
    :class:`InputError` for a missing column, a non-numeric / non-finite / non-positive value, a
    row of the wrong length, P_in outside [0, sqrt(3) V_ll_rms I_rms], or fewer than 3 rows."""
    file = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{file}: cannot read: {exc}") from None
    header, hline, rows = None, None, []
    for lineno, fields in _csv_lines(text, file):
        if header is None:
            header, hline = [h.strip() for h in fields], lineno
            continue
        rows.append((lineno, fields))
    if header is None:
        raise InputError(f"{file}: line 1: empty file: a header line {','.join(REQUIRED)}[,P_in] is needed")
    for name in REQUIRED:
        if name not in header:
            raise InputError(f"{file}: line {hline}: missing column {name!r} (header {header!r}; "
                             f"the columns are {', '.join(REQUIRED)} and optionally P_in)")
    for name in header:
        if name not in REQUIRED + OPTIONAL:
            raise InputError(f"{file}: line {hline}: unknown column {name!r} (the columns are "
                             f"{', '.join(REQUIRED)} and optionally P_in)")
        if header.count(name) > 1:
            raise InputError(f"{file}: line {hline}: column {name!r} appears twice")
    values = {name: [] for name in header}
    lines = []
    for lineno, fields in rows:
        if len(fields) != len(header):
            raise InputError(f"{file}: line {lineno}: {len(fields)} values {fields!r}, the header has "
                             f"{len(header)} columns")
        for name, raw in zip(header, fields):
            try:
                v = float(raw)
            except ValueError:
                raise InputError(f"{file}: line {lineno}: {name} = {raw.strip()!r} is not a number") from None
            if not math.isfinite(v):
                raise InputError(f"{file}: line {lineno}: {name} = {raw.strip()!r} is not finite")
            if name == "P_in":
                if v < 0.0:
                    raise InputError(f"{file}: line {lineno}: P_in = {raw.strip()!r} must be >= 0 [W]")
            elif v <= 0.0:
                raise InputError(f"{file}: line {lineno}: {name} = {raw.strip()!r} must be > 0")
            values[name].append(v)
        lines.append(lineno)
    cols = {k: np.array(v) for k, v in values.items()}
    if "P_in" in cols:
        S = math.sqrt(3.0) * cols["V_ll_rms"] * cols["I_rms"]
        for k in np.nonzero(cols["P_in"] > S)[0]:
            raise InputError(f"{file}: line {lines[k]}: P_in = {cols['P_in'][k]!r} W is greater than the "
                             f"apparent power sqrt(3) V_ll_rms I_rms = {S[k]:.6g} VA")
    if len(lines) < 3:
        where = f"line {lines[-1]}" if lines else f"line {hline}"
        raise InputError(f"{file}: {where}: {len(lines)} data row(s): at least 3 are needed (a curve family "
                         "has up to 3 parameters)")
    return cols, lines


def _csv_lines(text, file):
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        try:
            yield lineno, next(csv.reader([s]))
        except csv.Error as exc:  # a field over the csv module's limit (131 072 characters), a NUL, ...
            raise InputError(f"{file}: line {lineno}: not readable as CSV ({len(s)} characters): "
                             f"{exc}") from None


SPAN_MIN = 1.5  # max(i_mu) / min(i_mu) below this: the knee's shape is not in the data
LEVELS_MIN = 3  # distinct magnetizing-current levels (within 1 %) a 3-parameter family needs
RMS_WARN = 0.10  # the chosen fit's RMS above this share of the mean psi_m: no family describes the data


def undetermined(i_mu, psi_m, best):
    """Why the points cannot determine the curve (each a sentence naming what is missing), or []:
    fewer than LEVELS_MIN distinct current levels, a current span below SPAN_MIN, or a chosen fit
    whose RMS is above RMS_WARN of the mean flux."""
    import numpy as np

    out = []
    i = np.sort(np.asarray(i_mu, dtype=float))
    levels = 1 + int(np.count_nonzero(np.diff(i) > 0.01 * i[1:]))
    if levels < LEVELS_MIN:
        out.append(f"the points have {levels} distinct magnetizing-current level(s) (i_mu "
                   f"{i[0]:.4g}-{i[-1]:.4g} A): the curve is not determined, at least {LEVELS_MIN} are "
                   "needed (a test at several voltages, from well below the knee to above it)")
    elif i[-1] < SPAN_MIN * i[0]:
        out.append(f"i_mu spans only {i[0]:.4g}-{i[-1]:.4g} A (x{i[-1] / i[0]:.3g}): the knee's shape is "
                   f"not in the data, a span of at least x{SPAN_MIN:g} is needed (voltages "
                   "from about half the rated one to above it)")
    rel = best.rms / float(np.mean(psi_m))
    if rel > RMS_WARN:
        out.append(f"the chosen curve misses the points by {100 * rel:.3g} % RMS of the mean psi_m (more "
                   f"than {100 * RMS_WARN:g} %): no family describes these data; check the "
                   "readings and R_s, l_s")
    return out


def _float_option(name, raw):
    try:
        v = float(raw)
    except (TypeError, ValueError):
        v = None
    if v is None or not math.isfinite(v) or v < 0.0:
        raise InputError(f"{name} = {raw!r}: must be a finite number >= 0")
    return v


def _motor_option(name, raw):
    if name == "n_p":
        try:
            v = int(raw)
        except (TypeError, ValueError):
            v = 0
        if v < 1 or str(raw).strip() != str(v):
            raise InputError(f"--n-p = {raw!r}: must be an integer >= 1")
        return v
    v = _float_option(f"--{name.replace('_', '-')}", raw)
    if v == 0.0 and name in ("l_r", "R_r", "J"):
        raise InputError(f"--{name.replace('_', '-')} = {raw!r}: must be > 0")
    return v


def points_from_file(path, R_s, l_s, copper_tol=None, l_r=None, rel_sigma=None):
    """``(MagnetizingPoints, lines, has_P_in, losses)`` of a no-load file (``losses``: the
    :class:`~satmotor.identify.noload.LossSeparation`, None without P_in; the points carry their
    covariance from ``rel_sigma``, :func:`satmotor.identify.uncertainty.noload_points`);
    :class:`InputError` on bad input."""
    from satmotor.errors import ParameterError
    from satmotor.identify.noload import COPPER_TOL
    from satmotor.identify.uncertainty import REL_SIGMA, noload_points

    cols, lines = read_noload(path)
    tol = COPPER_TOL if copper_tol is None else copper_tol
    try:
        pts, losses = noload_points(cols["V_ll_rms"], cols["I_rms"], cols["f"], R_s, l_s, cols.get("P_in"),
                                    l_r, tol, REL_SIGMA if rel_sigma is None else rel_sigma)
    except ParameterError as exc:
        field = exc.field
        if "[" in field and field.split("[")[1].rstrip("]").isdigit():
            k = int(field.split("[")[1].rstrip("]"))
            raise InputError(f"{path}: line {lines[k]}: {field.split('[')[0]} = {exc.value!r}: "
                             f"{exc.reason}") from None
        raise InputError(f"{path}: {exc}") from None
    pts = pts._replace(warnings=tuple((lines[k], text) for k, text in pts.warnings))
    return pts, lines, "P_in" in cols, losses


def _overrides(fit):
    return {"curve": fit.family,
            **{k: (int(v) if k == "poly_n" else float(v)) for k, v in fit.params.items()}}


def write_outputs(out, source, pts, has_p, fits, failures, best, table, R_s, l_s, losses=None, rotor=None,
                  uncertainty=None):
    import yaml

    out = Path(out)
    i_t, psi_t, pooled = table
    with open(out / "curve_table.csv", "w", encoding="utf-8") as fh:
        fh.write(f"# magnetizing points of {source} (satmotor-cosim fit-curve); "
                 f"{pooled} point(s) pooled to make psi_m increase with i_mu\n")
        fh.write("i_mu,psi_m\n")
        for a, b in zip(i_t, psi_t):
            fh.write(f"{float(a)!r},{float(b)!r}\n")
    ov = _overrides(best)
    doc = {
        "plant": ov,
        "controller": dict(ov),
        "chosen": best.family,
        "fits": {name: {"rms_Wb": f.rms, "max_abs_Wb": f.max_abs, "chi2": f.chi2, "sigma_rel": f.sigma_rel,
                        "params": _overrides(f)}
                 for name, f in sorted(fits.items(), key=lambda kv: kv[1].score())},
        "input": {"file": str(source), "rows": int(pts.i_mu.size), "P_in": has_p, "R_s": R_s, "l_s": l_s},
    }
    if uncertainty is not None:
        doc["uncertainty"] = uncertainty
    if rotor is not None:
        doc["locked_rotor"] = {"l_s_H": rotor.l_s, "l_r_H": rotor.l_r, "R_r_Ohm": rotor.R_r,
                               "psi_m_Wb": rotor.psi_m}
    if losses is not None:
        doc["core_loss"] = {"R_fe_Ohm": losses.R_fe, "R_fe_plant_Ohm": losses.R_fe_plant,
                            "P_fw_W": losses.P_fw, "rms_W": losses.rms,
                            "lossless_rows": [line for line, _ in pts.warnings]}
    if failures:
        doc["failed"] = dict(failures)
    head = (f"# satmotor-cosim fit-curve {source} --R-s {R_s!r} --l-s {l_s!r}\n"
            "# Paste `plant:` and `controller:` into a scenario (both units use the same curve).\n"
            "# To use the measured points instead: {curve: table, table_file: <curve_table.csv of this\n"
            "# directory, relative to the scenario file>}.  `fits`: every family, RMS and largest residual\n"
            "# of psi_m [Wb] and chi-square, best (smallest chi-square) first; `uncertainty`: the chosen\n"
            "# curve's 1-sigma and the families the data cannot tell from it.\n")
    (out / "fit.yaml").write_text(head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None),
                                  encoding="utf-8")
    from orchestration.tools.fit_curve_figure import figure

    figure(out / "fit.png", source, pts, fits, best)


def prior(fit):
    """The chosen fit's parameters as a sweep's prior (``from: fit.yaml``, docs/scenarios.md): ``family``,
    ``parameters`` ``{name: {value, sigma}}`` [SI] and their ``covariance`` ``{parameters, matrix}``."""
    if fit.cov is None:
        return {}
    return {"family": fit.family,
            "parameters": {n: {"value": float(fit.params[n]), "sigma": s} for n, s in fit.sigma.items()},
            "covariance": {"parameters": list(fit.names),
                           "matrix": [[float(x) for x in row] for row in fit.cov]}}


def _rel_sigma_option(raw):
    from satmotor.identify.uncertainty import REL_SIGMA

    if raw is None:
        return REL_SIGMA
    try:
        v = tuple(float(x) for x in str(raw).split(","))
    except ValueError:
        v = ()
    if len(v) != 4 or not all(math.isfinite(x) and x > 0.0 for x in v):
        raise InputError(f"--rel-sigma = {raw!r}: must be four relative uncertainties > 0, for V_ll_rms, "
                         "I_rms, f and P_in (e.g. 0.01,0.01,0.001,0.01)")
    return v


MOTOR_OPTIONS = ("l_r", "R_r", "n_p", "J", "B")  # the motor parameters a no-load test does not give


def write_motor_yaml(path, source, best, R_s, l_s, losses, motor=None, rivals=None):
    """The ``motor:`` section of the fitted motor (with the plant's ``R_fe``), to paste into a scenario."""
    import yaml

    motor = {k: v for k, v in (motor or {}).items() if v is not None}
    if "l_r" not in motor and l_s > 0.0:
        motor["l_r"] = l_s  # as the rotor-leakage correction assumed
    section = {"R_s": R_s, "l_s": l_s, **motor, **_overrides(best)}
    rest = [name for name in ("R_r", "l_r", "k", "n_p", "J", "B") if name not in section]
    if losses is not None:  # plant only (the controller's model ignores it), in motor: like the rest
        section["R_fe"] = losses.R_fe_plant if losses.R_fe_plant is not None else losses.R_fe
    doc = {"motor": section}
    head = (f"# satmotor-cosim fit-curve {source}: the motor identified from a no-load test, to paste\n"
            "# into a scenario (motor: sets the plant and the controller's model alike; R_fe the plant\n"
            "# only).\n"
            + (f"# Not given, so the default motor's: {', '.join(rest)}.\n" if rest else ""))
    if losses is not None:
        head += (f"# Core loss: R_fe = {losses.R_fe!r} Ohm across E_m (the no-load separation; 0: none "
                 f"found), the plant's (across v_s - R_s i_s, ahead of l_s) R_fe = {section['R_fe']!r} Ohm; "
                 f"friction and windage at no load P_fw = {losses.P_fw:.6g} W.\n")
    if best.sigma_rel is not None:
        also = ", ".join(f"{k} (up to {100 * v:.2g} % off)" for k, v in (rivals or {}).items())
        head += (f"# Curve ({best.family}): 1-sigma {100 * best.sigma_rel:.2g} % of psi_m over the measured "
                 "current range, for the readings' stated uncertainty"
                 + (f"; the data fit {also} as well" if also else "") + ".\n")
    Path(path).write_text(head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=False),
                          encoding="utf-8")


def _locked_rotor_option(raw):
    from satmotor.machine.forms import LockedRotorTest

    try:
        v = [float(x) for x in str(raw).split(",")]
    except ValueError:
        v = []
    if len(v) != 4 or not all(math.isfinite(x) for x in v) or min(v[0], v[1], v[3]) <= 0.0 or v[2] < 0.0:
        raise InputError(f"--locked-rotor = {raw!r}: must be V_ll_rms,I_rms,P_in,f (four numbers: V > 0, "
                         "A > 0, W >= 0, Hz > 0)")
    return LockedRotorTest(*v)


def leakage_from_locked_rotor(path, R_s, test, ratio, tol, rel_sigma=None):
    """``(l_s, l_r, R_r)`` from the locked-rotor test and the no-load file (the curve and R_fe
    identified at each trial l_s; :func:`satmotor.identify.locked_rotor.leakage_from_tests`)."""
    from scipy.optimize import brentq, least_squares

    from satmotor.errors import ParameterError
    from satmotor.identify.curve_fit import choose, fit_all
    from satmotor.identify.locked_rotor import leakage_from_tests

    def identify_at(l_s):
        pts, _, _, losses = points_from_file(path, R_s, l_s, tol, ratio * l_s, rel_sigma)
        fits, _ = fit_all(pts.i_mu, pts.psi_m, least_squares, pts.cov)
        if not fits:
            raise InputError(f"{path}: no curve family could be fitted at l_s = {l_s!r} H")
        return choose(fits).curve, (losses.R_fe if losses is not None else 0.0)

    try:
        rb, _, _ = leakage_from_tests(R_s, test, identify_at, ratio,
                                      root=lambda f, a, b: brentq(f, a, b, xtol=1e-15, rtol=1e-13))
    except ParameterError as exc:
        raise InputError(f"--locked-rotor: {exc}") from None
    return rb


def run(path, R_s, l_s, out=DEFAULT_OUT, stream=None, copper_tol=None, motor_yaml=None, motor=None,
        locked_rotor=None, leakage_ratio=None, rel_sigma=None):
    """Fit the no-load file ``path`` and write the outputs; returns the chosen :class:`Fit`.
    ``copper_tol`` [1] (default ``COPPER_TOL``); ``motor_yaml``: also write the motor section there;
    ``motor``: ``{name: value}`` of :data:`MOTOR_OPTIONS` (None: not given); ``locked_rotor``:
    ``"V_ll_rms,I_rms,P_in,f"`` of a locked-rotor test, which then gives l_s (``l_s`` None), l_r and
    R_r with ``l_r = leakage_ratio l_s`` (default 1); ``rel_sigma``: ``"V,I,F,P"`` relative uncertainties
    (default 1 % each).
    Raises :class:`InputError` for bad input or an unwritable ``out``."""
    from scipy.optimize import least_squares

    from satmotor.errors import ParameterError
    from satmotor.identify.curve_fit import RIVAL_CHI2, choose, fit_all, monotone_table, rivals

    stream = sys.stdout if stream is None else stream
    R_s = _float_option("--R-s", R_s)
    tol = None if copper_tol is None else _float_option("--copper-tol", copper_tol)
    sig = _rel_sigma_option(rel_sigma)
    motor = {k: (None if v is None else _motor_option(k, v)) for k, v in (motor or {}).items()}
    rb = None
    if locked_rotor is not None:
        if l_s is not None or motor.get("l_r") is not None or motor.get("R_r") is not None:
            raise InputError("--locked-rotor gives l_s, l_r and R_r: leave out --l-s, --l-r and --R-r")
        ratio = 1.0 if leakage_ratio is None else _float_option("--leakage-ratio", leakage_ratio)
        if ratio <= 0.0:
            raise InputError(f"--leakage-ratio = {leakage_ratio!r}: must be > 0")
        rb = leakage_from_locked_rotor(path, R_s, _locked_rotor_option(locked_rotor), ratio, tol, sig)
        l_s = rb.l_s
        motor.update(l_r=rb.l_r, R_r=rb.R_r)
    elif l_s is None:
        raise InputError("--l-s is needed (or --locked-rotor, which gives it)")
    l_s = _float_option("--l-s", l_s)
    pts, lines, has_p, losses = points_from_file(path, R_s, l_s, tol, motor.get("l_r"), sig)
    try:
        fits, failures = fit_all(pts.i_mu, pts.psi_m, least_squares, pts.cov)
        table = monotone_table(pts.i_mu, pts.psi_m)
    except ParameterError as exc:
        raise InputError(f"{path}: lines {lines[0]}-{lines[-1]}: {exc}") from None
    if not fits:
        raise InputError(f"{path}: no curve family could be fitted: {failures}")
    best = choose(fits)
    rv = rivals(fits, best, float(pts.i_mu.min()), float(pts.i_mu.max()))
    unc = {"rel_sigma": dict(zip(("V_ll_rms", "I_rms", "f", "P_in"), sig)), "sigma_rel": best.sigma_rel,
           "rivals": rv, **prior(best)}
    try:
        Path(out).mkdir(parents=True, exist_ok=True)
        write_outputs(out, path, pts, has_p, fits, failures, best, table, R_s, l_s, losses, rb, unc)
    except OSError as exc:
        raise InputError(f"--out {out}: cannot write the results: {exc}") from None
    if motor_yaml is not None:
        try:
            write_motor_yaml(motor_yaml, path, best, R_s, l_s, losses, motor, rv)
        except OSError as exc:
            raise InputError(f"--motor-yaml {motor_yaml}: cannot write: {exc}") from None
    for line, text in pts.warnings:
        print(f"warning: {path}: line {line}: {text}", file=sys.stderr)
    print(f"{path}: {pts.i_mu.size} points, i_mu {pts.i_mu.min():.4g}-{pts.i_mu.max():.4g} A, psi_m "
          f"{pts.psi_m.min():.4g}-{pts.psi_m.max():.4g} Wb"
          + ("" if has_p else "; no P_in column: the line current is taken as purely magnetizing (too high "
             "at low voltage, where friction and iron-loss current are a large part of it: record P_in, or "
             "leave out the rows below about half the rated voltage)"),
          file=stream)
    print(f"  {'family':12s} {'RMS [mWb]':>10s} {'max [mWb]':>10s} {'chi2':>9s}  parameters", file=stream)
    for name, f in sorted(fits.items(), key=lambda kv: kv[1].score()):
        params = ", ".join(f"{k}={v:.6g}" for k, v in f.params.items())
        print(f"  {name:12s} {f.rms * 1e3:10.4g} {f.max_abs * 1e3:10.4g} {f.chi2:9.4g}  {params}"
              + ("  <- chosen" if f is best else ""), file=stream)
    for name, why in failures.items():
        print(f"  {name:12s} not fitted: {why}", file=stream)
    print(f"  uncertainty: the chosen curve within {100 * best.sigma_rel:.2g} % (1 sigma, largest over "
          f"i_mu {pts.i_mu.min():.4g}-{pts.i_mu.max():.4g} A) for readings within "
          + "/".join(f"{100 * v:.2g}" for v in sig) + " % (V_ll_rms/I_rms/f/P_in)"
          + ("" if not rv else f"; fitting the data as well (chi-square within {RIVAL_CHI2:g}): "
             + ", ".join(f"{k} (up to {100 * v:.2g} % off the chosen)" for k, v in rv.items())),
          file=stream)
    for text in undetermined(pts.i_mu, pts.psi_m, best):
        print(f"warning: {path}: {text}", file=sys.stderr)
    if pts.i_mu.size < 5:
        print(f"  only {pts.i_mu.size} points: the 3-parameter families are barely determined; "
              "measure 6-10 voltage levels", file=stream)
    if table[2]:
        print(f"  curve_table.csv: {table[2]} point(s) pooled so that psi_m increases with i_mu", file=stream)
    if rb is not None:
        print(f"  locked rotor: l_s = {rb.l_s:.6g} H, l_r = {rb.l_r:.6g} H, R_r = {rb.R_r:.6g} Ohm "
              f"(main flux {rb.psi_m:.4g} Wb in the test)", file=stream)
    if losses is not None:
        print(f"  core loss: R_fe = {losses.R_fe:.6g} Ohm" + (" (none found)" if losses.R_fe == 0.0 else
                                                                f" across E_m, {losses.R_fe_plant:.6g} Ohm "
                                                                "in the plant's placement")
              + f", friction and windage {losses.P_fw:.4g} W (fit RMS {losses.rms:.3g} W)", file=stream)
    print(f"  written: {Path(out) / 'fit.yaml'}, curve_table.csv, fit.png"
          + (f", {motor_yaml}" if motor_yaml is not None else ""), file=stream)
    return best

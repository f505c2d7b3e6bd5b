"""Command line: ``satmotor-cosim {build,run,batch,validate,check,export-ssp,fit-curve,efficiency-map}`` (also
``python -m orchestration``; the usage lines name the command as it was typed).

Exit codes: 0 success; 1 a run failed (FMI discard/error/fatal, or setup); 2 a scenario file is
invalid, or ``--out`` cannot be written (found before anything runs); 3 a run completed but
missed its acceptance bounds (a run that does not hold its set-points says so in its first line and
in ``metrics.json``, ``holds_setpoints``; it exits 3 only with ``acceptance: {holds_setpoints: true}``,
else 0: :mod:`orchestration.results.writer` says why); 130 / 143
interrupted by SIGINT (Ctrl-C) / SIGTERM, after writing
what was computed (status ``interrupted``).  ``batch`` exits with the largest code of its
scenarios (see :mod:`orchestration.cli.batch`).  ``check``: 1 if a check FAILs, 2 for a path that is not an
FMU or without the ``check`` extra (see :mod:`orchestration.check.checker`).  ``fit-curve``: 2 for a bad
no-load file or option (see :mod:`orchestration.tools.fit_curve`), 1 without the ``fit`` extra.  ``run
--engine libcosim``: 1 without the ``libcosim`` extra; ``run --engine c`` with the pythonfmu FMUs: 2,
refused.  A missing extra is one line naming the ``pip install``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from functools import partial
from pathlib import Path

from orchestration.packaging import fmus
from orchestration.process.clean_exit import exit_now

OK, RUN_FAILED, INVALID, NOT_ACCEPTED = 0, 1, 2, 3


def missing_extra(module, extra, what):
    """None when ``module`` can be imported, else the one line to print: ``what`` needs the extra ``extra``
    (pyproject.toml; docs/dependencies.md says why each is there)."""
    import importlib.util

    try:
        if importlib.util.find_spec(module) is not None:
            return None
    except (ImportError, ValueError):
        pass
    return f'{what}, which is not installed: pip install "satmotor[{extra}]"'


def model_variables(fmu_dir):
    """``{"plant": {name: (causality, type)}, "controller": ...}`` from the built FMUs, or None."""
    plant, ctrl = fmus.paths(fmu_dir)
    if not (plant.exists() and ctrl.exists()):
        return None
    from orchestration.run.c_engine.prepared import description  # parsed once per FMU content

    return {unit: unit_variables(description(path))
            for unit, path in (("plant", plant), ("controller", ctrl))}


def unit_variables(md):
    """``{name: (causality, type)}`` of a model description, the type by its FMI 2.0 name (``Real``,
    ``Integer``, ...) whatever the FMU's version, as the scenario's checks name them."""
    from orchestration.run.fmu_instance import FMI3_TYPES

    fmi2_name = {v: k for k, v in FMI3_TYPES.items()}
    return {v.name: (v.causality, fmi2_name.get(v.type, v.type)) for v in md.modelVariables}


def cmd_build(args):
    """``build [--out DIR] [--all-platforms] [--if-stale]``: 0 built (or up to date), 1 the build failed
    or cannot cross-compile (no zig)."""
    if args.all_platforms:
        from orchestration.packaging.fmu_build import NO_ZIG
        from orchestration.packaging.native.compiler import zig_available

        if not zig_available():
            print(NO_ZIG, file=sys.stderr)
            return RUN_FAILED
    if args.if_stale and fmus.up_to_date(args.out, args.all_platforms):
        print(f"{args.out}: up to date, nothing built")
    else:
        try:
            fmus.build(args.out, all_platforms=args.all_platforms)
        except subprocess.CalledProcessError as exc:
            print(f"building the FMUs into {args.out} failed (exit {exc.returncode})", file=sys.stderr)
            return RUN_FAILED
    for p in fmus.paths(args.out):
        print(p)
    return OK


def cmd_validate(args):
    """Every problem of each file (exit 2 if any), and the notes of the valid ones (plant/controller
    mismatch, a load beyond the current limit's torque: said on stderr, exit 0)."""
    from orchestration.cli.batch import collect
    from orchestration.scenario.validate import check_scenario_file, scenario_name, variant_count

    files = collect(args.scenario)  # the files batch would run: a directory's *.yaml
    if not files:
        print("no scenario files found", file=sys.stderr)
        return INVALID
    worst, names = OK, {}
    for path in files:
        problems, notes = check_scenario_file(path, model_variables(args.fmus))
        for p in [*problems, *notes]:
            print(p, file=sys.stderr)
        n = None if problems else variant_count(path)
        said = ([f"{n} variants, every one checked"] if n is not None else []) + (
            [f"{len(notes)} note(s)"] if notes else [])
        status = f"{len(problems)} problem(s)" if problems else "valid" + (
            f" ({', '.join(said)})" if said else "")
        print(f"{path}: {status}")
        worst = max(worst, INVALID if problems else OK)
        if not problems:
            names.setdefault(scenario_name(path), []).append(str(path))
    for name, fs in names.items():  # batch refuses them: they would write the same results directory
        if len(fs) > 1:
            print(f"scenario name {name!r} is used by {len(fs)} files (batch would refuse them: they would "
                  f"write the same results directory): {', '.join(fs)}", file=sys.stderr)
            worst = INVALID
    return worst


def run_file(path, out, fmu_dir, algorithm=None, build=True, plot=True, stop=None,
             variant=fmus.DEFAULT_VARIANT, engine="fmpy", figure_process=False, sweep_index=None,
             shared=None):
    """Load, run and write one scenario; returns (exit code, summary dict).

    Checked before any FMU runs: the scenario (every problem at once), that ``engine`` can run it
    (``libcosim``: :func:`orchestration.run.libcosim_engine.problems`) and that ``out`` can be
    written.  The time series stream to disk as the run goes; ``stop`` (an
    :class:`orchestration.process.interrupts.StopRequest`) ends the run early with what it has.
    ``figure_process``: draw the figure with a helper process that imports matplotlib while the
    run steps (:mod:`orchestration.results.figure_process`; used where it gains something).
    ``sweep_index``: run that variant of the file's sweep (:mod:`orchestration.scenario.sweep`)
    instead of the file's own scenario.  ``shared``: a :class:`SharedFMUs` (the FMUs extracted and
    their variables read once for several runs of one process), or None."""
    from orchestration.results.atomic import describe
    from orchestration.results.recorder import FILES
    from orchestration.results.running import figure_step
    from orchestration.results.writer import figure_target, prepare_dir, streaming_recorder, write_results
    from orchestration.run.master import run
    from orchestration.scenario.load import ScenarioError, load_scenario
    from orchestration.scenario.variants import load_variant

    def refused(message, name=Path(path).stem, write_failed=False):
        said = {"write_failed": True} if write_failed else {}  # --out not writable: not the file's fault
        return INVALID, {"scenario": name, "file": str(path), "status": "invalid", "message": message, **said}

    try:
        if build:
            fmus.ensure(fmu_dir, quiet=True)
        variables = shared.variables if shared is not None else model_variables(fmu_dir)
        if sweep_index is None:
            sc = load_scenario(path, variables)
        else:
            sc = load_variant(path, sweep_index, variables)
    except ScenarioError as exc:
        return refused(str(exc))
    except subprocess.CalledProcessError as exc:
        return RUN_FAILED, {"scenario": Path(path).stem, "file": str(path), "status": "setup",
                            "message": f"building the FMUs into {fmu_dir} failed (exit {exc.returncode})",
                            "rows": 0, "wall_time": 0.0}
    if engine == "libcosim":
        from orchestration.run import libcosim_engine

        found = libcosim_engine.problems(sc, algorithm)
        if variant not in libcosim_engine.VARIANTS:
            found.append(f"--variant {variant}: the libcosim engine runs the FMI 2.0 FMUs "
                         f"({', '.join(libcosim_engine.VARIANTS)})")
        if found:
            return refused("\n".join(map(str, found)), sc.name)
        run = partial(libcosim_engine.run, signals_cache=Path(fmu_dir) / "signals")  # built once per profiles
    elif engine == "c":
        from orchestration.run import c_engine

        found = c_engine.problems(variant)
        if found:
            return refused("\n".join(found), sc.name)
        run = c_engine.run
    from orchestration.results import out_lock

    try:  # one writer per results directory: a second run onto it is refused naming the first
        lock = out_lock.acquire(Path(out) / sc.name, f"run {path}")
    except out_lock.OutInUse as exc:
        return refused(f"--out {out}: {exc}", sc.name)
    except OSError as exc:
        return refused(f"--out {out}: cannot write the results: {describe(exc)}", sc.name, True)
    try:
        try:
            directory = prepare_dir(out, sc)
        except OSError as exc:
            return refused(f"--out {out}: cannot write the results: {describe(exc)}", sc.name, True)
        plant, ctrl = fmus.paths(fmu_dir, variant)
        helper = None
        plot = plot and sc.record.level != "metrics"  # no time series: no figure
        # the helper reads the Parquet file back (every figure_step-th row): only a full one
        if plot and figure_process and sc.record.level == "full":
            from orchestration.results import figure_process as fp

            try:
                helper = (fp.FigureProcess(directory / FILES[1], *figure_target(sc, out),
                                           step=figure_step(sc)) if fp.wanted() else None)
            except OSError:  # no fork today: the figure is drawn here
                helper = None
        make = streaming_recorder(sc, directory, on_parquet=helper and helper.parquet_done,
                                  figure_copy=helper is None)
        try:
            extra = ({"unzip_dirs": shared.dirs, "descriptions": shared.descriptions}
                     if shared is not None and engine in ("fmpy", "c") else {})
            if shared is None and engine == "fmpy":  # the descriptions parsed once per FMU content
                from orchestration.run.c_engine.prepared import description

                extra["descriptions"] = (description(plant), description(ctrl))
            if shared is not None and engine == "c":  # the FMUs instantiated once, reset per variant
                extra["pool"] = shared.pool
            result = run(sc, str(plant), str(ctrl), algorithm=algorithm, stop=stop, recorder=make, **extra)
            summary = write_results(result, out, plot=plot, draw=helper and helper.draw,
                                    write_error=make.error, discard_figure=helper and helper.discard)
        except OSError as exc:  # a file of the run could not be written: said, never a traceback
            return RUN_FAILED, {"scenario": sc.name, "file": str(path), "status": "failed", "rows": 0,
                                "wall_time": 0.0, "message": f"{describe(exc)}: the results are not complete",
                                "metrics_written": False}
        finally:
            if helper is not None:
                helper.close()
        if summary["status"] == "interrupted":
            return stop.exit_code, summary
        if summary["status"] != "ok":
            return RUN_FAILED, summary
        return (NOT_ACCEPTED if summary["accepted"] is False else OK), summary
    finally:
        out_lock.release(lock)


class SharedFMUs:
    """The two FMUs of ``variant`` extracted once, and their model descriptions read once, for the
    runs of one process (several variants of a sweep: :func:`cmd_run`); with ``--engine c`` the instances
    too (:attr:`pool`: instantiated once, reset per variant); :meth:`close` frees them and removes the
    copies.  ``variables``: as :func:`model_variables` gives them."""

    def __init__(self, fmu_dir, variant):
        from fmpy import read_model_description

        from orchestration.run.fmu_instance import UnitPool, extract_owned

        self.dirs = []
        self.pool = UnitPool()  # the instances of the c engine's runs (fmi2Reset/fmi3Reset per variant)
        try:
            paths = fmus.paths(fmu_dir, variant)
            for p in paths:
                self.dirs.append(extract_owned(p))
            self.descriptions = [read_model_description(str(p)) for p in paths]
            self.variables = {unit: unit_variables(md)
                              for unit, md in zip(("plant", "controller"), self.descriptions)}
        except BaseException:
            self.close()
            raise

    def close(self):
        from orchestration.run.fmu_instance import remove_extracted

        self.pool.close()  # the instances first, then their directories
        for d in self.dirs:
            remove_extracted(d)
        self.dirs = []


def indexes(text):
    """``--sweep-variant``: ``I`` or ``I,J,...`` (integers >= 0) -> a list."""
    try:
        out = [int(x) for x in text.split(",")]
    except ValueError:
        out = []
    if not out or min(out) < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: an index I >= 0, or indexes I,J,...")
    return out


def cmd_run(args):
    from orchestration.process.interrupts import catch, die_with_parent

    if args.engine == "libcosim":
        missing = missing_extra("libcosimpy", "libcosim", "--engine libcosim needs libcosimpy "
                                "(its only wheel: CPython 3.11, Linux x86_64)")
        if missing:
            print(missing, file=sys.stderr)
            return RUN_FAILED
    die_with_parent()
    code, several = OK, len(args.sweep_variant or ()) > 1
    with catch() as stop:
        variant = args.variant or ("native" if args.engine in ("libcosim", "c") else fmus.DEFAULT_VARIANT)
        shared = None
        try:
            if several and args.engine in ("fmpy", "c"):  # several variants: the FMUs extracted once
                if not args.no_build:
                    fmus.ensure(args.fmus, quiet=True)
                shared = SharedFMUs(args.fmus, variant)
            for index in args.sweep_variant or [None]:
                if stop.signum:  # the variants not started have no results: the batch says so
                    break
                c, s = run_file(args.scenario, args.out, args.fmus, args.algorithm, build=not args.no_build,
                                variant=variant, engine=args.engine, plot=not args.no_plot, stop=stop,
                                figure_process=not several, sweep_index=index, shared=shared)
                code = max(code, c) if not stop.signum else stop.exit_code
                _say(s, args.out)
                if args.batch_rows:  # the batch's row of this run even when its metrics.json is not on disk
                    from orchestration.results.batch_summary import report_line

                    print(report_line(s), flush=True)
        finally:
            if shared is not None:
                shared.close()
    return code


def _say(s, out):
    """What ``run`` prints of one run's summary ``s``."""
    if s.get("status") == "invalid":
        print(s["message"], file=sys.stderr)
        return
    for note in s.get("notes") or ():
        print(note, file=sys.stderr)
    for warning in s.get("warnings") or ():  # what an FMU logged at warning level
        print(f"warning: {warning}", file=sys.stderr)
    if s.get("metrics_written") is False:  # the one place left to say it (a batch shows this line)
        print(f"{s['scenario']}: failed: {s['message']}", file=sys.stderr)
    held = f", {s['setpoints']}" if s.get("holds_setpoints") is False else ""
    print(f"{s['scenario']}: {s['status']}" + (f" ({s['message']})" if s.get("message") else "") + held
          + f", {s['rows']} rows, {s['wall_time']:.2f} s wall, results in {Path(out) / s['scenario']}")
    if s.get("setpoints") and not held:
        print(f"  {s['setpoints']}")
    for key, v in (s.get("metrics") or {}).items():
        print(f"  {key:27s} {v:.6g}")
    for key, v in (s.get("acceptance") or {}).items():
        said = f"{v['value']}" if isinstance(v["limit"], bool) else f"{v['value']:.4g} <= {v['limit']:.4g}"
        print(f"  accept {key:20s} {said}: {'pass' if v['pass'] else 'FAIL'}")


def cmd_batch(args):
    from orchestration.cli.batch import run_batch
    from orchestration.process.interrupts import catch

    with catch() as stop:
        return run_batch(args.scenarios, args.out, args.fmus, jobs=args.jobs, scheduler=args.scheduler,
                         algorithm=args.algorithm, stop=stop, variant=args.variant or fmus.DEFAULT_VARIANT,
                         command=main, plot=not args.no_plot)


def cmd_check(args):
    from orchestration.check import checker as check

    missing = missing_extra("fmu_manipulation_toolbox", "check",
                            "check needs fmu-manipulation-toolbox (its second FMI 2.0 compliance checker)")
    if missing:
        print(missing, file=sys.stderr)
        return INVALID
    problems = [p for p in map(check.usage_problem, args.fmu) if p]
    for p in problems:
        print(p, file=sys.stderr)
    if problems:
        return INVALID
    return check.run(args.fmu, args.junit, args.reference)


def cmd_export_ssp(args):
    """``export-ssp SCENARIO OUT.ssp``: 0 written, 2 the scenario is invalid or SSP cannot express it
    (nothing written), 1 building the FMUs failed."""
    from orchestration.packaging.native.compiler import NativeBuildError
    from orchestration.scenario.load import ScenarioError, load_scenario
    from orchestration.tools.ssp import NotExpressible, NotWritable, export

    try:
        fmus.ensure(args.fmus, quiet=True)
        sc = load_scenario(args.scenario, model_variables(args.fmus))
        plant, ctrl = fmus.paths(args.fmus, args.variant)
        out = export(sc, args.out, plant, ctrl)
        print(out)
        from orchestration.tools.ssp import FMPY_NOTE

        print(FMPY_NOTE.format(name=out.name, step=repr(sc.step), stem=out.stem), file=sys.stderr)
    except (ScenarioError, NotExpressible, NotWritable) as exc:
        print(exc, file=sys.stderr)
        return INVALID
    except subprocess.CalledProcessError as exc:
        print(f"building the FMUs into {args.fmus} failed (exit {exc.returncode})", file=sys.stderr)
        return RUN_FAILED
    except NativeBuildError as exc:
        print(f"building ScenarioSignals.fmu failed: {exc}", file=sys.stderr)
        return RUN_FAILED
    return OK


def cmd_fit_curve(args):
    missing = missing_extra("scipy", "fit", "fit-curve needs scipy (its least_squares)")
    if missing:
        print(missing, file=sys.stderr)
        return RUN_FAILED
    from orchestration.tools.fit_curve import InputError, run

    try:
        run(args.noload, args.R_s, args.l_s, args.out, copper_tol=args.copper_tol, motor_yaml=args.motor_yaml,
            motor={k: getattr(args, k) for k in ("l_r", "R_r", "n_p", "J", "B")},
            locked_rotor=args.locked_rotor, leakage_ratio=args.leakage_ratio, rel_sigma=args.rel_sigma)
    except InputError as exc:
        print(exc, file=sys.stderr)
        return INVALID
    return OK


def cmd_efficiency_map(args):
    """``efficiency-map SCENARIO --speed FROM:TO:N --torque FROM:TO:N --out DIR [--flux-mode ...]``:
    :mod:`orchestration.tools.efficiency_map` (exit 2: a bad argument, naming it and its value)."""
    from orchestration.cli.batch import run_batch
    from orchestration.process.interrupts import catch
    from orchestration.tools.efficiency_map import ArgumentError, parse_grid, parse_modes, run_map

    try:
        speeds, torques = parse_grid(args.speed, "--speed"), parse_grid(args.torque, "--torque")
        modes = parse_modes(args.flux_mode)
        if args.jobs < 1:
            raise ArgumentError(f"--jobs {args.jobs}: must be >= 1")
        if not Path(args.scenario).is_file():
            raise ArgumentError(f"SCENARIO {args.scenario!r}: no such file")
    except ArgumentError as exc:
        print(f"efficiency-map: {exc}", file=sys.stderr)
        return INVALID
    with catch() as stop:
        try:
            return run_map(run_batch, args.scenario, args.out, speeds, torques, modes, args.fmus,
                           jobs=args.jobs, stop=stop, stop_time=args.time, window=args.window,
                           plot=not args.no_plot, variant=args.variant or "native", command=main)
        except ArgumentError as exc:
            print(f"efficiency-map: {exc}", file=sys.stderr)
            return INVALID


def prog_name(argv0=None):
    """The command as the user typed it, for the usage lines: ``python -m orchestration`` when run as
    the module, else the name of the script (``satmotor-cosim``)."""
    name = os.path.basename(sys.argv[0] if argv0 is None else argv0)
    if name == "__main__.py":
        return "python -m orchestration"
    return name if name and not name.startswith("-") else "satmotor-cosim"


def parser(prog="satmotor-cosim"):
    ap = argparse.ArgumentParser(prog=prog,
                                 description="Co-simulate the saturated induction motor FMU with the "
                                 "backstepping controller FMU over YAML scenarios (fmpy master).")
    sub = ap.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build the FMUs", description="Build the nine FMUs into OUT: "
                       "SaturatedInductionMotor.fmu and BacksteppingController.fmu (pythonfmu, FMI 2.0), "
                       "their native C twins in OUT/native (FMI 2.0) and OUT/native-fmi3 (FMI 3.0), and the "
                       "plant as model exchange in OUT/native-me and OUT/native-me-fmi3 "
                       "(SaturatedInductionMotorME.fmu), and the clocked controller (FMI 3.0 Scheduled "
                       "Execution) in OUT/native-fmi3-clocked; for this machine (Linux x86_64) unless "
                       "--all-platforms.")
    b.add_argument("--out", default=str(fmus.DEFAULT_DIR), help="output directory (default build/fmus)")
    b.add_argument("--all-platforms", action="store_true",
                   help="the native FMUs for Windows and macOS too (cross-compiled with zig, from the "
                   "ziglang wheel; minutes on a fresh machine), the Linux binary for glibc 2.17 and later: "
                   "the distributable FMUs (`make dist`)")
    b.add_argument("--if-stale", action="store_true",
                   help="build only when an FMU is missing or was built from other sources (as run does)")
    b.set_defaults(func=cmd_build)

    def common(p):
        p.add_argument("--out", default="results", help="results directory (default results)")
        p.add_argument("--fmus", default=str(fmus.DEFAULT_DIR),
                       help="FMU directory, built there when missing or stale (default build/fmus)")
        p.add_argument("--algorithm", choices=("gauss-seidel", "jacobi"),
                       help="override the scenario's coupling algorithm")
        p.add_argument("--variant", choices=tuple(fmus.VARIANTS),
                       help="which FMUs run: python (pythonfmu: they run the Python package satmotor, the "
                       "reference the C code is checked against; default; native with --engine c or "
                       "libcosim), "
                       "native (C, FMI 2.0) or native-fmi3 (C, FMI 3.0); the results are bit-identical, the "
                       "native ones 5.25x (FMI 3.0: 4.96x) faster under the fmpy master (bench/RESULTS.md)")

    r = sub.add_parser("run", help="run one scenario", description="Run one scenario; write timeseries "
                       "(CSV, Parquet), metrics.json and figure.png under OUT/<scenario name>/.")
    r.add_argument("scenario", help="scenario YAML file")
    common(r)
    r.add_argument("--no-build", action="store_true", help="do not build the FMUs, use them as they are")
    r.add_argument("--no-plot", action="store_true", help="skip the figure")
    r.add_argument("--batch-rows", action="store_true", help=argparse.SUPPRESS)  # batch's children only
    r.add_argument("--sweep-variant", type=indexes, metavar="I[,J,...]",
                   help="run variant I (from 0) of the file's sweep: section, or variants I, J, ... one "
                   "after the other in this process (batch runs them all); without it, run runs the "
                   "file's own scenario")
    r.add_argument("--engine", choices=("fmpy", "c", "libcosim"), default="fmpy",
                   help="co-simulation engine: fmpy (our master, default), c (the master's loop compiled, "
                   "the native FMUs, results bit-identical to fmpy; see orchestration/run/c_engine/) or "
                   "libcosim (OSP's C++ engine, Jacobi coupling, FMI 2.0 FMUs; see "
                   "orchestration/run/libcosim_engine.py)")
    r.set_defaults(func=cmd_run)
    ba = sub.add_parser("batch", help="run many scenarios in parallel", description="Run every scenario "
                        "(files, or the *.yaml of directories), one process each, and every variant of a "
                        "file's sweep: section; a summary table of the metrics goes to OUT/summary.csv and "
                        "the screen, a sweep's table and figure to OUT/<sweep name>/sweep.{csv,parquet,png}.")
    ba.add_argument("scenarios", nargs="+", help="scenario files or directories")
    common(ba)
    ba.add_argument("--jobs", type=int, default=2, help="parallel processes (default 2)")
    ba.add_argument("--no-plot", action="store_true",
                    help="no figure: neither the runs' nor the sweeps' (the tables are written)")
    ba.add_argument("--scheduler", help="address of a Dask distributed scheduler (e.g. tcp://host:8786); "
                    "the workers must see the same files")
    ba.set_defaults(func=cmd_batch)
    v = sub.add_parser("validate", help="check scenario files", description="Check scenario files against "
                       "the schema and the FMUs' variables; list every problem.")
    v.add_argument("scenario", nargs="+", help="scenario YAML files or directories (their *.yaml, as batch "
                   "runs them)")
    v.add_argument("--fmus", default=str(fmus.DEFAULT_DIR), help="FMU directory whose variables to check")
    v.set_defaults(func=cmd_validate)
    c = sub.add_parser("check", help="check FMUs (any FMI 2.0 or 3.0 co-simulation FMU)", description="Check "
                       "any FMI 2.0 or FMI 3.0 co-simulation FMU: fmpy validate, fmu-manipulation-toolbox "
                       "(FMI 2.0 only), and run-time checks in child processes (instantiate, wrong-guid, "
                       "cycles, state, foreign-state, reset, bad-parameter, non-finite-input, steps, "
                       "source-build, reference; a model-exchange FMU: me-instantiate, me-states, "
                       "me-events, me-reference); "
                       "one line per check; exit 1 if any FAILs, 2 for a path that is not an FMU.")
    c.add_argument("fmu", nargs="+", help="FMU file(s)")
    c.add_argument("--junit", metavar="FILE", help="write the results as JUnit XML")
    c.add_argument("--reference", metavar="DIR", help="directory holding <modelName>/ reference results "
                   "(default: the reference results installed with the package, reference/ of the checkout)")
    c.set_defaults(func=cmd_check)
    e = sub.add_parser("export-ssp", help="write a scenario as an SSP 1.0 package", description="Write "
                       "SCENARIO as an SSP 1.0 package: SystemStructure.ssd (components plant, controller, "
                       "signals; connections; the scenario's parameters; libcosim step-size annotations) and "
                       "the three FMUs, ScenarioSignals.fmu holding the scenario's profiles.")
    e.add_argument("scenario", help="scenario YAML file")
    e.add_argument("out", help="the .ssp file to write")
    e.add_argument("--fmus", default=str(fmus.DEFAULT_DIR),
                   help="FMU directory, built there when missing or stale (default build/fmus)")
    e.add_argument("--variant", choices=("native", "python"), default="native",
                   help="plant and controller FMUs: native (C, FMI 2.0; default) or python (pythonfmu)")
    e.set_defaults(func=cmd_export_ssp)
    fc = sub.add_parser("fit-curve", help="magnetizing curve from a no-load test", description="Fit every "
                        "magnetizing-curve family to a no-load test (CSV: V_ll_rms, I_rms, f[, P_in]); write "
                        "fit.yaml (scenario overrides), curve_table.csv (for curve: table) and fit.png.")
    fc.add_argument("noload", help="no-load test CSV file")
    fc.add_argument("--R-s", dest="R_s", required=True, metavar="OHM", help="stator resistance [Ohm]")
    fc.add_argument("--l-s", dest="l_s", default=None, metavar="H",
                    help="stator leakage inductance [H] (or --locked-rotor)")
    fc.add_argument("--locked-rotor", dest="locked_rotor", default=None, metavar="V,I,P,F",
                    help="locked-rotor test: V_ll_rms [V], I_rms [A], P_in [W], f [Hz]; gives l_s, l_r and "
                    "R_r (with --leakage-ratio l_r/l_s, default 1), written into --motor-yaml")
    fc.add_argument("--leakage-ratio", dest="leakage_ratio", default=None, metavar="RATIO",
                    help="l_r / l_s for --locked-rotor (IEEE 112: 1 design A and D, 1.5 B, 7/3 C; default 1)")
    fc.add_argument("--out", default="results/fit_curve", help="output directory (default results/fit_curve)")
    fc.add_argument("--copper-tol", dest="copper_tol", default=None, metavar="REL",
                    help="P_in this far (relative) below the stator copper loss is taken as lossless, with a "
                    "warning; further below, the row is refused (default 0.05)")
    fc.add_argument("--rel-sigma", dest="rel_sigma", default=None, metavar="V,I,F,P",
                    help="relative standard uncertainty of each column V_ll_rms, I_rms, f, P_in (default "
                    "0.01,0.01,0.01,0.01): weights the fit and sets the reported uncertainty")
    fc.add_argument("--motor-yaml", dest="motor_yaml", default=None, metavar="FILE",
                    help="also write a ready motor: section (and plant: {R_fe: ...}) for a scenario")
    for opt, dest, unit, what in (("--l-r", "l_r", "H", "rotor leakage inductance (default: l_s)"),
                                  ("--R-r", "R_r", "OHM", "rotor resistance"),
                                  ("--n-p", "n_p", "N", "pole pairs"), ("--J", "J", "KG_M2", "inertia"),
                                  ("--B", "B", "N_M_S", "viscous friction")):
        fc.add_argument(opt, dest=dest, default=None, metavar=unit,
                        help=f"{what} [{unit.replace('_', ' ')}], written into --motor-yaml")
    fc.set_defaults(func=cmd_fit_curve)
    em = sub.add_parser("efficiency-map", help="steady-state efficiency over a torque-speed grid",
                        description="Run the steady state of SCENARIO's drive at every point of a speed x "
                        "torque grid (negative torque: generating) and flux mode, in parallel; write "
                        "efficiency_map.csv, .parquet and .png into OUT (docs/scenarios.md).")
    em.add_argument("scenario", help="scenario YAML file: its motor, plant, controller, step and psi_ref")
    em.add_argument("--speed", required=True, metavar="FROM:TO:N", help="speed set-points [rad/s], N values")
    em.add_argument("--torque", required=True, metavar="FROM:TO:N", help="load torques [N m], N values")
    em.add_argument("--out", required=True, help="output directory")
    em.add_argument("--flux-mode", dest="flux_mode", default="nominal", metavar="M[,M]",
                    help="controller flux_mode(s): nominal, loss_minimizing or both (default nominal)")
    em.add_argument("--time", type=float, default=None, metavar="S",
                    help="run time per point [s] (default the scenario's stop_time)")
    em.add_argument("--window", type=float, default=None, metavar="S",
                    help="final averaging window [s] (default 10 %% of --time)")
    em.add_argument("--jobs", type=int, default=2, help="parallel processes (default 2)")
    em.add_argument("--fmus", default=str(fmus.DEFAULT_DIR),
                    help="FMU directory, built there when missing or stale (default build/fmus)")
    em.add_argument("--variant", choices=tuple(fmus.VARIANTS),
                    help="which FMUs (default native: the compiled engine)")
    em.add_argument("--no-plot", action="store_true", help="no efficiency_map.png")
    em.set_defaults(func=cmd_efficiency_map)
    return ap


#: exit status when the reader of our standard output went away (``... | head``): 128 + SIGPIPE,
#: what a shell reports for a command a broken pipe ended
BROKEN_PIPE = 141


def single_threaded_blas():
    """Before numpy is first imported: OpenBLAS limited to one thread (``OPENBLAS_NUM_THREADS=1``,
    unless the environment says otherwise), for this process and the children it starts.  A command's
    numpy does no linear algebra large enough for threads (OpenBLAS runs the small products of the
    curve fits on one thread whatever the setting), and starting its pool of threads costs about 50 ms
    CPU of every process that imports numpy (``bench/bench_startup.py``)."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def joined_grids(argv):
    """``--speed -150:150:5`` read as ``--speed=-150:150:5``: argparse takes a value starting with ``-``
    (a generating torque's) for an option unless it is a plain number."""
    out, argv = [], list(argv)
    for i, a in enumerate(argv):
        grid = i and argv[i - 1] in ("--speed", "--torque") and out and out[-1] == argv[i - 1]
        if grid and a.startswith("-"):
            out[-1] = f"{argv[i - 1]}={a}"
        else:
            out.append(a)
    return out


def main(argv=None):
    single_threaded_blas()
    own = argv is None  # this process's own command line
    argv = joined_grids(sys.argv[1:] if own else argv)
    args = parser(prog_name() if own else "satmotor-cosim").parse_args(argv)
    try:
        code = args.func(args)
    except BrokenPipeError:  # the reader closed the pipe: no traceback, nothing more to print
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # the final flush must not fail again
        code = BROKEN_PIPE
    if own:  # this process's own command line (python -m orchestration, satmotor-cosim):
        exit_now(code)  # end it here, before native exit code runs (see orchestration/process/clean_exit.py)
    return code

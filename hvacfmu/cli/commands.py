"""Command line: ``hvacfmu <command> ...``.

The CLI only parses arguments and calls one library function per command
(imports are lazy so ``hvacfmu --help`` is instant). Each command lives in its
own ``_cmd_<name>`` function below.
"""

from __future__ import annotations

import argparse
import logging
import sys
import warnings


def _building_arg(p, required=True):
    p.add_argument("--building", "-b", required=required, help="building file (TOML)")


def _data_args(p):
    p.add_argument("data", help="measurements file (CSV or Parquet)")
    _building_arg(p)
    p.add_argument("--step", type=float, default=900.0, help="model step [s] (default 900)")
    p.add_argument("--seed", type=int, default=0, help="seed of the train/test week split (default 0)")
    p.add_argument(
        "--interpolate-gaps",
        type=float,
        default=None,
        metavar="MINUTES",
        help="linearly interpolate gaps of every column, zone temperatures included, up to this length when "
        "loading (default: keep every gap; evaluate fills input gaps by itself, see --fill-inputs)",
    )
    p.add_argument(
        "--timezone",
        default=None,
        help="time zone of the data's naive timestamps, e.g. UTC (default: the building's data_timezone, "
        "else its timezone)",
    )


def _load_dataset(args):
    import hvacfmu as hf

    return hf.prepare(
        args.data,
        args.building,
        step=args.step,
        seed=args.seed,
        interpolate_limit=args.interpolate_gaps,
        timezone=args.timezone,
        progress=not args.quiet,
    )


# --------------------------------------------------------------------------- check
def _cmd_check(args):
    import hvacfmu as hf

    report = hf.check(
        args.data,
        args.building,
        step=args.step,
        seed=args.seed,
        interpolate_limit=args.interpolate_gaps,
        timezone=args.timezone,
        progress=not args.quiet,
    )
    if report.ok:
        _physics_note(report, args)
    print(report)
    return report.exit_code


def _physics_note(report, args) -> None:
    """Name, as a note, what keeps ``fit --kind physics`` from building its network from the building file's tables.

    The data-driven kinds do not read the physics tables, so this does not make the data unusable; but the
    user learns it from ``check`` rather than from a later ``fit`` or ``demo``.
    """
    from ..data.loading import as_building
    from ..models.physics import physics_problems

    building = as_building(args.building, args.timezone)
    problems = physics_problems(building)
    if problems and problems[0].startswith("no [[elements]] or [[constructions]] tables"):
        return  # no physics tables at all: the user fits the data-driven kinds (fit --kind physics says what it needs)
    if problems:
        shown = "; ".join(problems[:5]) + (f"; and {len(problems) - 5} more" if len(problems) > 5 else "")
        report.warnings.append(
            f"building file: the physics model (fit --kind physics) cannot be built from its tables "
            f"({len(problems)} problem(s)): {shown}"
        )


# --------------------------------------------------------------------------- generate
def _cmd_generate(args):
    if args.engine == "energyplus":
        if args.schedule != "always-on":
            from ..emulator import EmulatorError

            raise EmulatorError(
                f"--schedule {args.schedule} is an emulator option; the EnergyPlus prototypes run their own "
                "HVAC schedules (their systems already shut off outside the occupied hours): drop --schedule"
            )
        from ..energyplus import generate_from_args

        print(generate_from_args(args))
        return 0
    import hvacfmu as hf

    from ..emulator import parse_effect

    effects = [parse_effect(e) for e in (args.effect or [])]
    paths = hf.generate(
        args.outdir,
        weeks=51 if args.weeks is None else args.weeks,
        seed=args.seed,
        effects=effects,
        fmt=args.format,
        layout=args.layout,
        construction=args.construction,
        climate=args.climate,
        start=args.start or "2025-09-01",
        hvac=args.hvac,
        units=args.units,
        clock=args.clock,
        export_step=args.export_step,
        faults=args.fault or (),
        holidays=args.holidays,
        wind=args.wind,
        schedule=args.schedule,
    )
    print(paths)
    return 0


def _cmd_generate_fleet(args):
    from ..emulator import generate_fleet

    path = generate_fleet(args.n, args.outdir, seed=args.seed, weeks=args.weeks, progress=True)
    print(f"fleet manifest: {path}")
    return 0


# --------------------------------------------------------------------------- fit
def _cmd_fit(args):
    import hvacfmu as hf

    options = {}
    if args.heat is not None:
        if args.model not in ("lumped", "zones"):
            print(
                f"hvacfmu: error: --heat applies to Model A (lumped, zones), not {args.model}; the physics model "
                "always uses each box's Td_<vav> where measured",
                file=sys.stderr,
            )
            return 2
        options["heat"] = args.heat
    if args.gain_days is not None:
        if args.model != "physics":
            print(
                f"hvacfmu: error: --gain-days applies to the physics model (its step 2 gain profile), not "
                f"{args.model}; drop the option, or fit --model physics",
                file=sys.stderr,
            )
            return 2
        options["gain_days"] = args.gain_days
    if args.couplings:
        if args.model != "zones":
            print(
                f"hvacfmu: error: --couplings applies to the six-zone Model A (zones), not {args.model}; "
                "drop the option, or fit --model zones",
                file=sys.stderr,
            )
            return 2
        options["open_loop_couplings"] = True
    dataset = _load_dataset(args)
    model = hf.fit(dataset, args.model, progress=not args.quiet, **options)
    path = model.save(args.output)
    print(f"saved {args.model} model to {path}")
    summary = getattr(model, "summary", None)
    if callable(summary):
        print(summary())
    return 0


# --------------------------------------------------------------------------- evaluate
def _cmd_evaluate(args):
    import hvacfmu as hf

    dataset = _load_dataset(args)
    result = hf.evaluate(
        args.model if len(args.model) > 1 else args.model[0],
        dataset,
        horizon=args.horizon,
        fill_inputs_h=args.fill_inputs,
        min_output_share=args.min_output_share / 100.0,
    )
    print(result.format())
    if args.interpolate_gaps is not None:
        print(
            f"note: --interpolate-gaps {args.interpolate_gaps:g} filled gaps of up to {args.interpolate_gaps:g} min in "
            "every column when loading, the zone temperatures included, so these scores count interpolated "
            "temperatures as measured; evaluate scores only measured outputs by itself (inputs filled across gaps "
            "up to --fill-inputs hours): drop --interpolate-gaps to score measured temperatures only"
        )
    if args.json:
        result.save_json(args.json)
        print(f"wrote {args.json}")
    if args.plots:
        files = result.plot(args.plots, dataset=dataset, week=args.week)
        print("wrote " + ", ".join(str(f) for f in files))
    return 0


# --------------------------------------------------------------------------- export
def _cmd_export(args):
    from ..fmu import export_file

    path = export_file(args.model, args.output, timezone=args.timezone, native=args.native, building=args.building)
    print(f"wrote {path}")
    return 0


# --------------------------------------------------------------------------- cosim
def _cmd_cosim(args):
    from harness.cosim import main_cosim

    return main_cosim(args)


# --------------------------------------------------------------------------- diagnose
def _cmd_diagnose(args):
    import hvacfmu as hf

    dataset = _load_dataset(args)
    opts = {} if args.max_terms is None else {"max_terms": args.max_terms}
    report = hf.diagnose(dataset, model=args.model, plots=args.plots, progress=not args.quiet, **opts)
    print(report.format())
    if args.json:
        report.save_json(args.json)
        print(f"wrote {args.json}")
    if args.output:
        report.model.save(args.output)
        print(f"saved extended model to {args.output}")
    if args.control_output:
        from ..diagnosis.control import terms_on_base

        terms = report.model.terms if report.findings else ()
        control = terms_on_base(dataset, report.base_model, terms, meta={"name": "extended (control)"})
        control.save(args.control_output)
        on = (
            "the delivered-heat form of the base model (the data measure the discharge air)"
            if (control.meta or {}).get("control_base", {}).get("heat") == "delivered"
            or getattr(control.base, "beta", None) is not None
            else "the base model's own dynamics"
        )
        print(
            f"saved the model to control with to {args.control_output}: {len(control.terms)} found term(s) refitted "
            f"on {on} (README 'Control gain of the diagnosis')"
        )
    return 0


# --------------------------------------------------------------------------- demo
def _cmd_demo(args):
    from .demo import run_demo

    result = run_demo(args.out, weeks=args.weeks, seed=args.seed, mpc_horizon=args.horizon, progress=not args.quiet)
    print(result)
    return 1 if result.failed else 0


def _cmd_fleet(args):
    from ..fleet import fleet

    result = fleet(
        args.source,
        stages=args.stages,
        out=args.out,
        scheduler=args.scheduler,
        n_workers=args.workers,
        kinds=tuple(args.kind or ("lumped", "zones")),
        progress=False if args.quiet else None,
    )
    print(result.summary())
    print(f"table: {result.out / 'fleet.parquet'} and fleet.csv; report: {result.out / 'report.html'}")
    return 1 if result.failed else 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hvacfmu",
        description="Thermal models of HVAC zones from measured data, as FMI 2.0 FMUs, with MPC.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    for add in (
        _add_check_parser,
        _add_generate_parser,
        _add_generate_fleet_parser,
        _add_fit_parser,
        _add_evaluate_parser,
        _add_export_parser,
        _add_cosim_parser,
        _add_diagnose_parser,
        _add_demo_parser,
        _add_fleet_parser,
    ):
        add(sub)
    return parser


def _add_check_parser(sub) -> None:
    """The ``check`` subcommand."""
    p = sub.add_parser(
        "check",
        help="load and validate a dataset; print coverage, gaps, seasons, split",
        description="Load and validate a dataset. Exit code 0: usable (notes at most); 1: not usable (every "
        "problem listed); 3: usable, but a warning needs action first (clock offset, unknown columns ignored, "
        "stuck sensor, discharge air against its unit), marked '!' and named on the final line.",
    )
    _data_args(p)
    p.set_defaults(func=_cmd_check)


def _add_generate_parser(sub) -> None:
    """The ``generate`` subcommand."""
    p = sub.add_parser("generate", help="write an emulated dataset (measurements, building.toml, truth.json)")
    p.add_argument("outdir")
    p.add_argument(
        "--engine",
        choices=("emulator", "energyplus"),
        default="emulator",
        help="emulator (default) or energyplus (pip install 'hvacfmu[energyplus]')",
    )
    p.add_argument("--weeks", type=int, default=None, help="length [weeks] (emulator default 51, energyplus: a year)")
    p.add_argument("--seed", type=int, default=0, help="emulator seed: same seed, same data (default 0)")
    p.add_argument(
        "--effect",
        action="append",
        metavar="NAME[:key=value,...]",
        help="inject an effect, e.g. solar_gain:zone=S or zone_coupling:zones=NW+C (repeatable)",
    )
    p.add_argument(
        "--format", choices=("parquet", "csv"), default="parquet", help="measurements file format (default parquet)"
    )
    p.add_argument(
        "--layout",
        choices=("sdh", "row4", "core9", "quad4", "ell5", "stack4"),
        default="sdh",
        help="floor layout: sdh (six zones, default), row4 (four-zone row), core9 (nine zones with a core), "
        "quad4 (2 x 2 corner offices), ell5 (L-shaped floor, five unequal zones, a meeting room), "
        "stack4 (a whole two-storey building, two zones per storey, roof and slab on grade)",
    )
    p.add_argument(
        "--construction",
        choices=("medium", "light", "heavy"),
        default="medium",
        help="construction template (default medium: the SDH-like concrete frame)",
    )
    p.add_argument(
        "--climate",
        choices=("mild", "cold", "hot"),
        default="mild",
        help="mild (Berkeley, default), cold (Chicago-like winters), hot (Phoenix-like summers)",
    )
    p.add_argument(
        "--start",
        default=None,
        metavar="YYYY-MM-DD",
        help="local start date (emulator default 2025-09-01, energyplus 2017-01-01)",
    )
    p.add_argument(
        "--hvac",
        choices=("vav", "reheat", "reheat-dual"),
        default="vav",
        help="vav (default), reheat: real-BMS-like VAV with reheat at constant minimum airflow, two air "
        "handlers, Td_/rh_ columns; reheat-dual: the same with dual-maximum boxes",
    )
    p.add_argument("--units", choices=("si", "us"), default="si", help="export units: si (default) or us (°F, CFM, %%)")
    p.add_argument(
        "--clock",
        choices=("aware", "naive-local", "naive-utc"),
        default="aware",
        help="timestamps: ISO with UTC offset (default), naive local wall clock, or naive UTC",
    )
    p.add_argument("--export-step", type=int, default=60, metavar="SECONDS", help="trend-log interval (default 60)")
    p.add_argument(
        "--fault",
        action="append",
        choices=("outages", "sparse_box", "stuck_sensor"),
        help="real-world export defect (repeatable)",
    )
    p.add_argument(
        "--holidays",
        metavar="COUNTRY",
        help="the building closes on the public holidays of COUNTRY (e.g. US): Sunday's occupancy and an "
        "unoccupied BMS schedule; the building file does not declare them (default: it never closes)",
    )
    p.add_argument(
        "--wind",
        metavar="UNIT",
        choices=("m/s", "km/h", "mph", "kn"),
        help="write the site's wind speed as a 'wind' column in UNIT (m/s, km/h, mph, kn; declared in the "
        "building file's [units]); default: no wind column",
    )
    p.add_argument(
        "--schedule",
        choices=("always-on", "night-off"),
        default="always-on",
        help="emulator HVAC schedule: always-on (default: boxes never below their minimum airflow, only set-backs "
        "at night) or night-off (system off outside the occupied hours: boxes at zero airflow, no reheat, the air "
        "handlers off and their T_supply reading the idle duct; restart 1 h before occupancy)",
    )
    from ..energyplus.cli import add_energyplus_arguments

    add_energyplus_arguments(p)
    p.set_defaults(func=_cmd_generate)


def _add_generate_fleet_parser(sub) -> None:
    """The ``generate-fleet`` subcommand."""
    p = sub.add_parser("generate-fleet", help="write N varied emulated buildings and a manifest fleet.json")
    p.add_argument("n", type=int, metavar="N")
    p.add_argument("outdir", metavar="DIR")
    p.add_argument("--weeks", type=int, default=51, help="length of every dataset (default 51)")
    p.add_argument("--seed", type=int, default=0, help="draws layouts, constructions, climates, effects, modes")
    p.set_defaults(func=_cmd_generate_fleet)


def _add_fit_parser(sub) -> None:
    """The ``fit`` subcommand."""
    from ..models.physics.identification import GAIN_DAYS
    from ..models.registry import fittable_kinds

    p = sub.add_parser("fit", help="identify a model from data")
    _data_args(p)
    p.add_argument(
        "--model",
        "-m",
        choices=fittable_kinds(),
        required=True,
        help="model kind (from the model-kind registry): " + ", ".join(fittable_kinds()),
    )
    p.add_argument("--output", "-o", required=True, help="model file to write (JSON)")
    p.add_argument(
        "--heat",
        choices=("auto", "airflow", "delivered"),
        help="Model A: how the boxes act (default auto: delivered heat m*cp*(Td - T_zone) when Td_<vav> "
        "are measured or an air handler is often off, else the paper's airflow form)",
    )
    p.add_argument(
        "--gain-days",
        choices=GAIN_DAYS,
        help="physics: step 2's internal-gain profile (default: the building file's [physics].gain_days, else "
        "'auto': the one of 'week' (the paper's per time of week), 'workdays' (Monday-Friday pooled) and 'shrunk' "
        "(pooled where the training weeks show no weekday pattern) with the lowest 24-h open-loop RMS in blocked "
        "cross-validation over the training weeks)",
    )
    p.add_argument(
        "--couplings",
        action="store_true",
        help="zones: the open-loop refinement also re-fits the couplings of adjacent zones (off-diagonal A; "
        "better perimeter zones on EnergyPlus years, worse cores in summer: see README, Model A step 4)",
    )
    p.set_defaults(func=_cmd_fit)


def _add_evaluate_parser(sub) -> None:
    """The ``evaluate`` subcommand."""
    p = sub.add_parser(
        "evaluate",
        help="verdict per zone against persistence and time-of-week (ASHRAE G14 NMBE, "
        "CV(RMSE)), then 24-hour open-loop RMS on held-out weeks (the paper's Table I)",
    )
    _data_args(p)
    p.add_argument("--model", "-m", action="append", required=True, help="model file (repeatable)")
    p.add_argument("--horizon", type=int, default=96, help="prediction horizon in steps (default 96 = 24 h)")
    p.add_argument(
        "--fill-inputs",
        type=float,
        default=2.0,
        metavar="HOURS",
        help="fill gaps of the inputs (airflows, Td, T_supply, weather) up to this length by linear interpolation "
        "in time for the simulation; a window with a longer input gap is skipped (default 2 h; 0: no filling). "
        "Zone temperatures are never filled: errors count measured steps only",
    )
    p.add_argument(
        "--min-output-share",
        type=float,
        default=75.0,
        metavar="PERCENT",
        help="score a window only when every output is measured in this share of its steps (default 75)",
    )
    p.add_argument("--json", help="write the result as JSON")
    p.add_argument("--plots", help="folder for figures (7-day open-loop trajectories)")
    p.add_argument(
        "--week",
        type=int,
        help="week number of the 7-day trajectory figure (default: the first spring test week, else the first test week)",
    )
    p.set_defaults(func=_cmd_evaluate)


def _add_export_parser(sub) -> None:
    """The ``export`` subcommand."""
    p = sub.add_parser("export", help="export a model as an FMI 2.0 co-simulation FMU")
    p.add_argument("model", help="model file (JSON), or an emulator truth.json for the plant FMU")
    p.add_argument("--output", "-o", required=True, help="FMU to write")
    p.add_argument(
        "--timezone",
        help="IANA time zone of the building (e.g. America/Los_Angeles); lets the FMU of a "
        "model with calendar terms (holidays) follow the calendar through its start_time parameter",
    )
    p.add_argument(
        "--building",
        "-b",
        help="building file (TOML) the model was fitted on: box airflow bounds "
        "(m_max) and zones in the model description",
    )
    p.add_argument(
        "--native",
        action="store_true",
        help="native FMU: the model as generated C code compiled "
        "with the system C compiler, no Python at run time (linear/bilinear model kinds)",
    )
    p.set_defaults(func=_cmd_export)


def _add_cosim_parser(sub) -> None:
    """The ``cosim`` subcommand."""
    p = sub.add_parser("cosim", help="co-simulate an FMU with a controller in the loop (FMPy)")
    try:
        from harness.cosim import add_cosim_arguments
    except ImportError:  # harness not available: keep the CLI usable
        add_cosim_arguments = None
    if add_cosim_arguments is not None:
        add_cosim_arguments(p)
    p.set_defaults(func=_cmd_cosim)


def _add_diagnose_parser(sub) -> None:
    """The ``diagnose`` subcommand."""
    p = sub.add_parser("diagnose", help="find what the model gets wrong, name the cause, extend the model")
    _data_args(p)
    p.add_argument("--model", "-m", help="base model file (default: fit the six-zone Model A)")
    p.add_argument("--json", help="write the report as JSON")
    p.add_argument("--plots", help="folder for diagnostic figures")
    p.add_argument(
        "--max-terms",
        type=int,
        help="term budget: at most this many terms are added (default max(20, 4 per zone)); the report names "
        "the significant candidates a budget reached left untried",
    )
    p.add_argument("--output", "-o", help="write the extended model (JSON)")
    p.add_argument(
        "--control-output",
        help="write the found terms refitted on the base model's own dynamics, or on its delivered-heat form where "
        "the data measure the discharge air Td_<vav> (JSON): the model for "
        "`cosim --controller mpc`; the one-step refit of --output forecasts well but has too small a "
        "first-step airflow response to control with",
    )
    p.set_defaults(func=_cmd_diagnose)


def _add_demo_parser(sub) -> None:
    """The ``demo`` subcommand."""
    p = sub.add_parser("demo", help="the paper end to end on the built-in emulated building, with a report")
    p.add_argument("--out", default="hvacfmu-demo", help="output folder (default ./hvacfmu-demo)")
    p.add_argument("--weeks", type=int, default=51, help="weeks of emulated 1-minute data (default 51, cached)")
    p.add_argument("--seed", type=int, default=0, help="emulator seed (default 0)")
    p.add_argument(
        "--horizon",
        type=int,
        default=None,
        help="MPC horizon in steps of 15 min (default: cosim's, 3 h = 12 steps; the paper used 3)",
    )
    p.set_defaults(func=_cmd_demo)


def _add_fleet_parser(sub) -> None:
    """The ``fleet`` subcommand."""
    from ..models.registry import fittable_kinds

    p = sub.add_parser("fleet", help="run check/fit/evaluate/diagnose/export over many buildings on Dask")
    p.add_argument("source", help="folder of building folders, a folder with fleet.json, or a manifest (.json/.csv)")
    p.add_argument(
        "--stages",
        default="check,fit,evaluate",
        help="comma-separated subset of check,fit,evaluate,diagnose,export (default check,fit,evaluate)",
    )
    p.add_argument("--out", default="hvacfmu-fleet", help="output folder (default ./hvacfmu-fleet)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, help="local workers (default: the machine's cores)")
    p.add_argument(
        "--kind",
        action="append",
        choices=fittable_kinds(),
        help="model kind to fit (repeatable; default lumped and zones)",
    )
    p.set_defaults(func=_cmd_fleet)


def _version():
    from .. import __version__

    return __version__


_default_showwarning = warnings.showwarning


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """hvacfmu's own warnings as one line ``HvacfmuWarning: ...`` (they name file, column and fix
    themselves; the library's source line means nothing to a user), others as Python shows them."""
    from ..errors import HvacfmuWarning

    if issubclass(category, HvacfmuWarning):
        print(f"{category.__name__}: {message}", file=file or sys.stderr)
    else:
        _default_showwarning(message, category, filename, lineno, file, line)


def main(argv=None) -> int:
    from ..errors import HvacfmuError

    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO, format="%(levelname)s %(name)s: %(message)s"
    )
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    warnings.simplefilter("default")
    warnings.showwarning = _show_warning
    try:
        return int(args.func(args) or 0)
    except HvacfmuError as exc:
        print(f"hvacfmu {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

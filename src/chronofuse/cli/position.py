"""``chronofuse position`` and ``chronofuse reproduce positioning``: GNSS, GNSS/INS and smoothed solutions."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from chronofuse.cli.common import (
    collected_warnings,
    fail,
    human_console,
    print_json,
    progress_reporter,
    quiet_output,
    run_reproduction,
    user_errors,
)
from chronofuse.cli.reproduce import reproduce_app
# what the help text names, without the simulation (chronofuse.gnss.simulate.ENVIRONMENTS is this same table)
from chronofuse.models.environment import signal_environments
from chronofuse.positioning import MAX_SPEED_M_PER_S, SYSTEMS

ENVIRONMENTS = tuple(signal_environments())

#: Options of the simulated drive only, and of the real files only (--obs): given with the other mode they
#: would do nothing, so they are refused. With --obs the INS options (--ins, --smooth, --coupling) need an IMU
#: log (--imu); the simulated IMU's rate is the log's own there.
SIMULATION_ONLY = {"scenario": "--environment", "duration": "--duration", "trials": "--trials", "seed": "--seed",
                   "imu_rate": "--imu-rate", "speed": "--speed"}
REAL_ONLY = {"reference": "--position", "start": "--start", "end": "--end", "mask_deg": "--elevation-mask-deg",
             "ionosphere": "--ionosphere", "troposphere": "--troposphere", "imu": "--imu", "coupling": "--coupling"}
#: With --obs, the options that need --imu.
IMU_ONLY = {"ins": "--ins", "smooth": "--smooth", "coupling": "--coupling"}


def _given(ctx: typer.Context, name: str) -> bool:
    """Whether option ``name`` was given on the command line (its source's name: typer has its own enum)."""
    return getattr(ctx.get_parameter_source(name), "name", None) == "COMMANDLINE"


def _refuse_other_mode(ctx: typer.Context, real: bool) -> None:
    table, mode = (SIMULATION_ONLY, "a simulated drive (without --obs)") if real else (REAL_ONLY, "--obs")
    given = [flag for name, flag in table.items() if _given(ctx, name)]
    if given:
        fail(f"{', '.join(given)}: only with {mode}; here {'it does' if len(given) == 1 else 'they do'} nothing"
             + (" (with --obs the IMU's rate is its log's: --imu)" if real and "--imu-rate" in given else ""))
    if real and not _given(ctx, "imu"):
        given = [flag for name, flag in IMU_ONLY.items() if _given(ctx, name)]
        if given:
            fail(f"{', '.join(given)}: with --obs only together with --imu (an IMU log); here "
                 f"{'it does' if len(given) == 1 else 'they do'} nothing")


def register(app: typer.Typer) -> None:
    app.command("position")(position)


def _table(summary: dict, title: str) -> Table:
    table = Table("solution", "CEP50 (m)", "CEP95 (m)", "vertical 95 % (m)", "availability",
                  "bridging 2 m / 10 m (s)", title=title)
    for name, m in summary["solutions"].items():
        b = m["bridging_s"]
        table.add_row(name, f"{m['cep50_m']:.2f}", f"{m['cep95_m']:.2f}", f"{m['vertical95_m']:.2f}",
                      f"{m['availability']:.1%}", f"{b['2m']:g} / {b['10m']:g}")
    return table


def _xyz(text: str) -> list[float]:
    parts = text.replace(" ", "").split(",")
    try:
        values = [float(v) for v in parts]
    except ValueError:
        values = []
    if len(values) != 3:
        fail(f"--position {text!r}: must be X,Y,Z (ECEF metres)")
    return values


def _file(path: Path, option: str) -> None:
    if path.is_dir():
        fail(f"{option} {path}: is a directory, not a file (give the file itself)")


def _real(obs: Path, nav: list[Path], systems: str, reference: str | None, start: float | None, end: float | None,
          mask_deg: float, ionosphere: str, troposphere: str, out: Path | None, json_out: bool,
          imu: Path | None = None, coupling: str = "loose", ins: str = "industrial", smooth: bool = False) -> None:
    """``position --obs``: single-point fixes from real files."""
    from chronofuse.experiments.real_positioning import position_from_files, write_positions_csv
    from chronofuse.gnss.point_positioning import SppOptions
    from chronofuse.gnss.systems import parse_systems

    from chronofuse.gnss.systems import system_names

    if not nav:
        fail("--obs needs at least one --nav (the broadcast navigation files of the same day)")
    _file(obs, "--obs")
    for p in nav:
        _file(p, "--nav")
    if imu is not None:
        _file(imu, "--imu")
    reference_m = _xyz(reference) if reference is not None else None
    with user_errors(), collected_warnings() as notes:
        letters = parse_systems(systems)
        options = SppOptions(elevation_mask_deg=mask_deg, ionosphere=ionosphere, troposphere=troposphere)
        solution = None
        if imu is None:
            fixes, summary = position_from_files(obs, nav, letters, options=options, start_s=start, end_s=end,
                                                 reference_m=reference_m)
        else:
            from chronofuse.experiments.real_ins import ins_from_files

            fixes, solution, summary = ins_from_files(obs, nav, imu, letters, coupling=coupling, grade=ins,
                                                      smooth=smooth, options=options, start_s=start, end_s=end,
                                                      reference_m=reference_m)
        files = []
        if out is not None:
            from chronofuse.report.jsonio import dumps

            out.mkdir(parents=True, exist_ok=True)
            if solution is None:
                rows = write_positions_csv(fixes, out / "positions.csv", reference_m)
                files = [str(out / "positions.csv")]
            else:
                from chronofuse.experiments.real_ins import as_point_positions

                # positions.csv: the GNSS/INS solution; the single-point fixes beside it for comparison
                rows = write_positions_csv(as_point_positions(fixes, solution.filtered, solution),
                                           out / "positions.csv", reference_m)
                write_positions_csv(fixes, out / "spp_positions.csv", reference_m)
                files = [str(out / "positions.csv"), str(out / "spp_positions.csv")]
                if solution.smoothed is not None:
                    write_positions_csv(as_point_positions(fixes, solution.smoothed, solution),
                                        out / "smoothed_positions.csv", reference_m)
                    files.append(str(out / "smoothed_positions.csv"))
            summary["csv_rows"] = rows
            (out / "summary.json").write_text(dumps(summary) + "\n")
            files.append(str(out / "summary.json"))
    summary["files"] = files
    summary["warnings"] = notes
    for note in notes:
        human_console(json_out).print(f"warning: {note}", markup=False, soft_wrap=True)
    if json_out:
        print_json(summary)
        return
    con = human_console(False)
    con.print(f"{obs}: {summary['receiver']}, {summary['fixes']:,} fixes of {summary['epochs']:,} epochs with "
              f"{system_names(letters)} ({', '.join(f'{k} {v}' for k, v in summary['codes'].items())}), "
              f"{summary['mean_satellites']:.1f} satellites on average, {summary['excluded_measurements']} excluded")
    if "statistics" in summary:
        s = summary["statistics"]
        con.print(f"  against the reference: horizontal 95 % {s['horizontal95_m']:.2f} m, vertical 95 % "
                  f"{s['vertical95_m']:.2f} m, CEP50 {s['cep50_m']:.2f} m, CEP95 {s['cep95_m']:.2f} m")
    elif "mean_position_m" in summary:
        con.print("  mean position (ECEF m): " + ", ".join(f"{v:.3f}" for v in summary["mean_position_m"]))
    if "ins" in summary:
        e = summary["ins"]
        con.print(f"  GNSS/INS ({e['coupling']}ly coupled, {e['grade']} IMU at {e['imu_rate_hz']:g} Hz): "
                  f"{e['epochs']:,} epochs, {e['gaps']} gap{'s' if e['gaps'] != 1 else ''} in the IMU log")
        for name, st in e.get("statistics", {}).items():
            con.print(f"    {name}: horizontal 95 % {st['horizontal95_m']:.2f} m, vertical 95 % "
                      f"{st['vertical95_m']:.2f} m on the same {st['fixes']:,} epochs")
    if files:
        con.print(f"  wrote {', '.join(files)}")


def position(
    ctx: typer.Context,
    obs: Path | None = typer.Option(None, "--obs", help="RINEX 2/3 observation file (plain, .gz, Hatanaka .crx/.crx.gz): "
                                    "single-point fixes from it instead of a simulated drive."),
    scenario: str = typer.Option("urban-canyon", "--environment",
                                 help=f"Signal environment of the simulated drive, one of {sorted(ENVIRONMENTS)}."),
    systems: str = typer.Option("gps+bds", "--systems", help=f"Simulation: one of {sorted(SYSTEMS)}. With --obs: gps, gal, "
                                "bds, qzss joined by + (e.g. gps+bds)."),
    ins: str = typer.Option("industrial", "--ins", help="IMU grade: none, consumer, industrial or tactical (with "
                            "--imu: the log's IMU, whose noise the filter assumes)."),
    smooth: bool = typer.Option(False, "--smooth", help="Add the RTS-smoothed GNSS/INS solution."),
    imu: Path | None = typer.Option(None, "--imu", help="With --obs: an IMU log (CSV, chronofuse.io.imu_log's "
                                    "columns) on GPS time: the GNSS/INS solution beside the single-point fixes."),
    coupling: str = typer.Option("loose", "--coupling", help="With --imu: loose (the fixes into the filter) or "
                                 "tight (the pseudoranges: fewer than four satellites still help)."),
    duration: float = typer.Option(600.0, "--duration", help="Drive length (s; 1 Hz GNSS)."),
    trials: int = typer.Option(10, "--trials", help="Monte Carlo trials."),
    seed: int = typer.Option(0, "--seed", help="Seed of the run."),
    imu_rate: float = typer.Option(100.0, "--imu-rate", help="IMU sample rate (Hz, at least 10)."),
    speed: float = typer.Option(12.0, "--speed", help=f"Vehicle speed (m/s, at most {MAX_SPEED_M_PER_S:g})."),
    nav: list[Path] | None = typer.Option(None, "--nav", help="RINEX navigation file (repeat for several). With --obs: "
                                          "the ephemerides of the fixes. Without: GPS orbits of the simulated drive "
                                          "from its broadcast ephemeris (the drive starts at its first record)."),
    reference: str | None = typer.Option(None, "--position", help="With --obs: the receiver's known antenna position "
                                         "X,Y,Z (m, ECEF); statistics against it."),
    start: float | None = typer.Option(None, "--start", help="With --obs: first epoch, after the file's first (s)."),
    end: float | None = typer.Option(None, "--end", help="With --obs: last epoch, after the file's first (s)."),
    mask_deg: float = typer.Option(10.0, "--elevation-mask-deg", help="With --obs: elevation mask (deg)."),
    ionosphere: str = typer.Option("klobuchar", "--ionosphere", help="With --obs: klobuchar (the broadcast GPS "
                                   "coefficients; a warning when the files have none) or none."),
    troposphere: str = typer.Option("saastamoinen", "--troposphere", help="With --obs: saastamoinen or none."),
    out: Path | None = typer.Option(None, "--out", help="Report folder: summary.json and PNG figures (with --obs: "
                                    "positions.csv and summary.json)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """Single-point fixes from a RINEX file (--obs), or a simulated drive comparing GNSS-only, GNSS/INS and
    (with --smooth) RTS-smoothed positions."""
    quiet_output(quiet)
    from chronofuse.experiments.positioning import PositioningConfig, run_positioning, write_report

    _refuse_other_mode(ctx, obs is not None)
    if obs is not None:
        _real(obs, list(nav or []), systems, reference, start, end, mask_deg, ionosphere, troposphere, out, json_out,
              imu, coupling, ins, smooth)
        return
    if nav is not None and len(nav) > 1:
        fail("--nav: a simulated drive takes one navigation file (several are for --obs)")
    nav = nav[0] if nav else None
    if imu_rate < 10.0:
        fail(f"--imu-rate == {imu_rate:g}, must be >= 10 Hz (a loosely coupled INS needs the motion sampled)")
    if not 0.0 < speed <= MAX_SPEED_M_PER_S:
        fail(f"--speed == {speed:g}, must be in (0, {MAX_SPEED_M_PER_S:g}] m/s (the scenarios' road vehicle)")
    with user_errors():
        cfg = PositioningConfig(scenario=scenario, systems=systems, ins=ins, smooth=smooth, duration_s=duration,
                                trials=trials, seed=seed, imu_rate_hz=imu_rate, speed_m_per_s=speed, nav=nav)
        with progress_reporter("position") as say:
            run = run_positioning(cfg, progress=say)
            files = write_report(run, out) if out is not None else []
    summary = run["summary"] | {"files": [str(p) for p in files]}
    if json_out:
        print_json(summary)
        return
    con = human_console(False)
    con.print(_table(summary, f"{scenario}, {systems}, INS {ins}: {trials} trials of {duration:g} s "
                              f"(mean GDOP {summary['gdop_mean']:.2f})"))
    if files:
        con.print(f"report -> {out}/")


@reproduce_app.command("positioning")
def reproduce_positioning(
    quick: bool = typer.Option(False, "--quick", help="Fewer, shorter drives (about a minute)."),
    out: Path = typer.Option(Path("out/reproduce/positioning"), "--out",
                             help="Report folder (created; docs/positioning holds the published run)."),
    seed: int = typer.Option(6300, "--seed", help="Root seed of every drive (6300: the published run)."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document on stdout."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors (and the --json document)."),
) -> None:
    """The GNSSDO paper's positioning claims (GPS+BDS+INS with smoothing) on the calibrated error budget, with
    intervals, beside ours and RTKLIB's fixes of the real stations."""
    quiet_output(quiet)
    from chronofuse.experiments.positioning_claims import reproduce_positioning_claims

    summary = run_reproduction("reproduce positioning", reproduce_positioning_claims, out, quick=quick,
                               json_out=json_out, seed=seed)
    if summary is None:
        return
    con = human_console(False)
    table = Table("claim", "the paper", "ours [95 % CI]", "floor [95 % CI]", "verdict",
                  title="The GNSSDO paper's positioning claims, measured")
    ci = lambda v, lo_hi: f"{v:.2f} [{lo_hi[0]:.2f}, {lo_hi[1]:.2f}]"  # noqa: E731
    for row in summary["claims"]:
        floor = row["floor"]
        table.add_row(row["claim"], f"{row['claimed']:g}", ci(row["ours"], row["ci95"]),
                      "-" if floor is None else ci(floor["value"], floor["ci95"]), row["verdict"])
    con.print(table)
    con.print(f"report -> {out}/")

"""``dcstereo batch``: match many pairs, here or on Dask; resume, report failures."""

import contextlib
import re

import click

from dcstereo._extras import require
from dcstereo.cli._common import (
    CommandError,
    apply_threads,
    compile_watch,
    depth_file_options,
    disparity_range_options,
    matching_options,
    one_line_errors,
    output_folder,
)

_LOCAL = re.compile(r"local:(\d+)$")


def scheduler_option(func):
    """Add the ``--scheduler`` option shared by ``batch`` and ``video``."""
    return click.option(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:PORT|local:N",
        help="Run one task per pair/frame on dask.distributed: the address of a running "
        "scheduler, or local:N to start a local cluster of N worker processes. Default: "
        "run here with all cores.",
    )(func)


@contextlib.contextmanager
def dask_client(scheduler):
    """Yield a ``distributed.Client`` for ``--scheduler`` (None: yield None).

    ``local:N`` starts (and at the end stops) a LocalCluster of N single-threaded worker
    processes; anything else is the address of a running scheduler.
    """
    if scheduler is None:
        yield None
        return
    try:
        distributed = require("distributed", "dask", "--scheduler and Dask clusters")
    except ImportError as exc:
        raise CommandError(str(exc)) from None
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    local = _LOCAL.match(scheduler)
    if scheduler.startswith("local"):
        if local is None or int(local[1]) < 1:
            raise CommandError(f"--scheduler local:N needs N >= 1 workers, got '{scheduler}'")
        with (
            LocalCluster(
                n_workers=int(local[1]),
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
            ) as cluster,
            Client(cluster) as client,
        ):
            yield client
        return
    try:
        client = Client(scheduler, timeout=10)
    except (OSError, TimeoutError, ValueError) as exc:
        raise CommandError(f"cannot connect to the Dask scheduler '{scheduler}': {exc}") from None
    with client:
        yield client


@contextlib.contextmanager
def progress_bar(unit: str, quiet: bool):
    """Give a rich progress bar on stderr: done, rate, time left (None when quiet).

    It is not started here but by :func:`advancer`'s first call, and stopped on leaving.
    """
    if quiet:
        yield None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        ProgressColumn,
        TextColumn,
        TimeRemainingColumn,
    )
    from rich.text import Text

    class RateColumn(ProgressColumn):
        def render(self, task):
            speed = task.finished_speed or task.speed
            return Text("" if speed is None else f"{speed:.2f} {unit}/s")

    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        RateColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=False,
    )
    try:
        yield bar
    finally:
        if bar.live.is_started:  # stop() prints a line break off a terminal, even unstarted
            bar.stop()


def advancer(bar, description: str, total: int):
    """Return a callback that advances BAR's task by one (None when BAR is None).

    The bar starts, with its task, at the first call, once the library has checked the
    options and the output folder: a refusal prints its one line and no bar.
    """
    if bar is None:
        return None
    task = []

    def advance(*_):
        if not task:
            bar.start()
            task.append(bar.add_task(description, total=total))
        bar.advance(task[0])

    return advance


@click.command()
@click.argument("source", type=click.Path(exists=True))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for <name>.pfm per pair, failures.csv and batch.json (created if missing).",
)
@disparity_range_options
@matching_options
@scheduler_option
@click.option(
    "--resume/--no-resume",
    default=True,
    show_default=True,
    help="Skip pairs whose output is already complete; --no-resume recomputes all.",
)
@click.option(
    "--retries",
    type=click.IntRange(0),
    default=2,
    show_default=True,
    help="Dask: times a task that failed unexpectedly is run again.",
)
@click.option(
    "--depth",
    is_flag=True,
    help="Also write each pair's depth map, OUTPUT/depth/<name>.pfm (float32, in the "
    "baseline's unit, inf = none), from --calib or from the calib.txt in each pair folder.",
)
@depth_file_options
@click.option(
    "--ply",
    is_flag=True,
    help="Also write each pair's point cloud, OUTPUT/cloud/<name>.ply (binary PLY, left "
    "camera frame, coloured by the left image), from --calib or each pair's calib.txt.",
)
@click.option(
    "--calib",
    type=click.Path(dir_okay=False),
    default=None,
    help="With --depth or --ply: one calibration for every pair (Middlebury's calib.txt format).",
)
@click.option(
    "--confidence",
    is_flag=True,
    help="Also write each pair's confidence map, OUTPUT/confidence/<name>.pfm (-1..1, "
    "inf = none; see dcstereo.refine.confidence).",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress bar; print only failures.")
@one_line_errors
def batch(
    source,
    output,
    max_disparity,
    min_disparity,
    match_options,
    threads,
    scheduler,
    resume,
    retries,
    depth,
    ply,
    depth_format,
    depth_scale,
    calib,
    confidence,
    quiet,
):
    """Match every pair of SOURCE and write OUTPUT/<name>.pfm for each.

    SOURCE is a CSV file of left,right[,name] rows (paths relative to the CSV), or a
    folder with one folder per pair holding left.* and right.* (or Middlebury's im0.*
    and im1.*, and calib.txt for --depth and --ply). A pair that fails is reported (and listed in
    OUTPUT/failures.csv) while the others go on; the exit code is 1 when any pair failed.
    """
    from dcstereo.batch.folders import FAILURES_FILE, find_pairs, run_batch
    from dcstereo.geometry import Calibration
    from dcstereo.params import MatchParams

    folder = output_folder(output)
    if calib is not None and not (depth or ply):
        raise CommandError("--calib is used only with --depth or --ply")
    if depth_format != "pfm" and not depth:
        raise CommandError("--depth-format is used only with --depth")
    if depth_scale is not None and depth_format != "png":
        raise CommandError("--depth-scale is used only with --depth-format png")
    calibration = None if calib is None else Calibration.from_middlebury(calib)
    pairs = find_pairs(source)
    # Refuse bad options before a cluster starts; run_batch makes the folder once valid.
    MatchParams(max_disparity=max_disparity, min_disparity=min_disparity, **match_options)
    apply_threads(threads, scheduler)
    # compile_watch: a first run's compiling is announced (here, not on a Dask cluster)
    with (
        progress_bar("pairs", quiet) as bar,
        dask_client(scheduler) as client,
        compile_watch(quiet),
    ):
        report = run_batch(
            pairs,
            folder,
            max_disparity=max_disparity,
            client=client,
            resume=resume,
            retries=retries,
            threads=threads if scheduler is not None else None,
            on_outcome=advancer(bar, "batch", len(pairs)),
            depth=depth,
            calibration=calibration,
            confidence=confidence,
            ply=ply,
            depth_format=depth_format,
            depth_scale=depth_scale,
            min_disparity=min_disparity,
            **match_options,
        )
    for outcome in report.failed:
        click.echo(f"failed: {outcome.pair.name}: {outcome.message}", err=True)
    if not quiet:
        click.echo(
            f"batch: {len(report.outcomes)} pairs, {len(report.done)} matched, "
            f"{len(report.skipped)} already complete, {len(report.failed)} failed, "
            f"{report.seconds:.1f} s -> {folder}"
        )
    if not report.ok:
        click.echo(
            f"Error: {len(report.failed)} of {len(report.outcomes)} pairs failed; "
            f"see {folder / FAILURES_FILE}",
            err=True,
        )
        raise SystemExit(1)

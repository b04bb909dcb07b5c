"""Options and error handling shared by the subcommands."""

import contextlib
import functools
from pathlib import Path

import click

from ..params import DEFAULT_OCCLUSION_COST, MAX_MEDIAN, METHODS, SUBPIXEL_FITS
from ..viz import PREVIEW_STYLES

#: Methods whose result carries feature pairs.
FEATURE_METHODS = ("dc", "dc-linear", "dsi3-gcp")

#: The keyword arguments of :func:`dcstereo.match` that :func:`matching_options` collects.
MATCH_OPTIONS = ("method", "window", "occlusion_cost", "cost", "fill", "subpixel", "median")


class CommandError(click.ClickException):
    """A one-line user-facing error (exit code 1)."""

    def show(self, file=None):
        """Print ``Error: <message>`` on one line, never a traceback."""
        click.echo(f"Error: {self.format_message()}", err=True, file=file)


def one_line_errors(func):
    """Turn the library's ValueError/TypeError/OSError into a one-line CLI error."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except (ValueError, TypeError, OSError) as exc:
            message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise CommandError(message) from None

    return wrapper


def check_output_paths(*paths):
    """Fail before any work when an output folder is missing or an output is a folder."""
    from ..io import check_writable

    for path in paths:
        if path is not None:
            try:
                check_writable(path)
            except ValueError as exc:
                raise CommandError(str(exc)) from None


def check_distinct_paths(inputs, outputs):
    """Fail before any work when an output is an input or two outputs are the same file.

    Parameters
    ----------
    inputs : dict of str to path or None
        What each input is (``"the left input"``) and its path; None entries are skipped.
        An input that is a folder (a scene) makes each existing file under it an input.
    outputs : dict of str to path or None
        The option of each output (``"--preview"``) and its path; None entries are skipped.
    """
    read = {Path(path).resolve(): what for what, path in inputs.items() if path is not None}
    folders = {path: what for path, what in read.items() if path.is_dir()}
    written = {}
    for option, path in outputs.items():
        if path is None:
            continue
        resolved = Path(path).resolve()
        if resolved in read:
            raise CommandError(f"{option} '{path}' is {read[resolved]}")
        # an input folder (a scene) is read whole: its existing files are inputs too
        inside = [what for folder, what in folders.items() if folder in resolved.parents]
        if inside and resolved.exists():
            raise CommandError(f"{option} '{path}' is a file of {inside[0]}")
        if resolved in written:
            raise CommandError(f"{option} and {written[resolved]} are the same file '{path}'")
        written[resolved] = option


@contextlib.contextmanager
def staged_outputs():
    """Write a command's outputs to temporary files and move them only if all succeed.

    Yields ``write(writer, path, *args, **kwargs)``, which calls ``writer(temporary,
    *args, **kwargs)`` with a hidden temporary file next to ``path`` (see
    :func:`dcstereo.io.atomic_writes`) and returns what the writer returns. When the block
    ends without an error, every temporary file is moved onto its path; on any error all
    of them are removed, and a move that fails partway puts back the files already moved,
    so a failed command leaves no partial set of outputs and pre-existing files untouched.
    """
    from .. import io

    with io.atomic_writes() as stage:

        def write(writer, path, *args, **kwargs):
            temporary = stage(path)
            try:
                return writer(temporary, *args, **kwargs)
            except (ValueError, TypeError, OSError) as exc:
                # the writer's message names the temporary file; the user knows the output
                raise ValueError(str(exc).replace(str(temporary), str(path))) from None

        yield write


def output_folder(output) -> Path:
    """Return OUTPUT as a folder path; fail when it exists and is not a folder."""
    folder = Path(output)
    if folder.exists() and not folder.is_dir():
        raise CommandError(f"cannot write into '{folder}': it is not a directory")
    return folder


def apply_threads(threads, scheduler=None):
    """Cap numba's threads here, or, with a Dask scheduler, check the per-worker count."""
    if scheduler is None:
        set_threads(threads)
    elif threads is not None and threads < 1:
        raise CommandError(f"--threads must be at least 1, got {threads}")


def disparity_range_options(func):
    """``--max-disparity`` (required) and ``--min-disparity`` (0): the inclusive search range."""
    func = click.option(
        "--min-disparity",
        type=int,
        default=0,
        show_default=True,
        help="Smallest disparity searched.",
    )(func)
    return click.option(
        "--max-disparity", required=True, type=int, help="Largest disparity searched."
    )(func)


#: ``--preview-style``: how a disparity preview is drawn.
preview_style_option = click.option(
    "--preview-style",
    type=click.Choice(PREVIEW_STYLES),
    default="paper",
    show_default=True,
    help="paper: histogram-equalized gray, occlusions brightest; color: turbo colour map.",
)


def set_threads(threads):
    """Cap numba's thread count (None keeps numba's default)."""
    if threads is None:
        return
    import numba

    if threads < 1 or threads > numba.config.NUMBA_NUM_THREADS:
        raise CommandError(
            f"--threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}, got {threads}"
        )
    numba.set_num_threads(threads)


def matching_options(func):
    """Options of :func:`dcstereo.match` shared by the matching commands, and ``--threads``.

    The command receives the options named in :data:`MATCH_OPTIONS` as one dict,
    ``match_options`` (keyword arguments of ``match``), and ``threads`` on its own; a new
    matching option is added here once, for every command.
    """
    options = [
        click.option(
            "--method",
            type=click.Choice(METHODS),
            default="dc",
            show_default=True,
            help="Matching method.",
        ),
        click.option(
            "--window",
            type=int,
            default=5,
            show_default=True,
            help="Odd side of the square SAD window.",
        ),
        click.option(
            "--occlusion-cost",
            type=float,
            default=DEFAULT_OCCLUSION_COST,
            show_default=True,
            help="Cost of one occluded pixel, in gray levels of mean absolute difference.",
        ),
        click.option(
            "--cost",
            type=click.Choice(["sad", "bt"]),
            default="sad",
            show_default=True,
            help="Matching cost: windowed SAD (the paper's eq. 4) or Birchfield-Tomasi "
            "(sampling-insensitive, summed over the same window).",
        ),
        click.option(
            "--fill/--no-fill",
            default=False,
            show_default=True,
            help="Fill occluded pixels with the background disparity (dense map).",
        ),
        click.option(
            "--subpixel",
            type=click.Choice(SUBPIXEL_FITS),
            default=None,
            help="Refine each whole-pixel disparity to a fraction of a pixel by this fit "
            "through the window costs at d - 1, d, d + 1 (before --fill; default: off).",
        ),
        median_option,
        click.option(
            "--threads",
            type=int,
            default=None,
            help="Number of threads (default: all cores).",
        ),
    ]
    return _option_group(func, "match_options", MATCH_OPTIONS, options)


#: ``--median K``: the post-filter of :mod:`dcstereo.postfilter`.
median_option = click.option(
    "--median",
    type=int,
    default=0,
    show_default=True,
    help="Median post-filter: every estimate but the feature pairs' takes the median of "
    f"the estimates in this odd square around it, 3 to {MAX_MEDIAN} (after --subpixel, "
    "before --fill; 0: off).",
)


def depth_file_options(func):
    """Add ``--depth-format pfm|png`` and ``--depth-scale S`` (batch and video's depth files)."""
    func = click.option(
        "--depth-scale",
        type=float,
        default=None,
        help="Stored value per unit of depth in a png depth map (default 1: millimetres for "
        "a baseline in mm).",
    )(func)
    return click.option(
        "--depth-format",
        type=click.Choice(["pfm", "png"]),
        default="pfm",
        show_default=True,
        help="The depth maps' format: pfm (float32, in the baseline's unit, inf = none) or "
        "png (16-bit, round(depth * --depth-scale), 0 = none).",
    )(func)


def _option_group(func, key, names, options):
    """Add ``options`` to the command ``func``, which gets those in ``names`` as one dict.

    The dict is the keyword argument ``key``; options not in ``names`` reach ``func`` on
    their own. ``options`` are listed as ``--help`` shows them.
    """

    @functools.wraps(func)
    def collect(*args, **kwargs):
        kwargs[key] = {name: kwargs.pop(name) for name in names}
        return func(*args, **kwargs)

    for option in reversed(options):
        collect = option(collect)
    return collect


#: The calibration options that :func:`calibration_options` collects, and their flags.
CALIBRATION_OPTIONS = {
    "calib": "--calib",
    "focal": "--focal",
    "baseline": "--baseline",
    "principal": "--principal",
    "doffs": "--doffs",
}


def calibration_options(func):
    """Add the pair's geometry, for depth and point clouds: ``--calib`` or ``--focal`` & co.

    The command receives them as one dict, ``calibration``; :func:`calibration_of` turns
    it into a :class:`dcstereo.geometry.Calibration`.
    """
    options = [
        click.option(
            "--calib",
            type=click.Path(dir_okay=False),
            default=None,
            help="Calibration file in Middlebury's calib.txt format (cam0=[f 0 cx; 0 f cy; "
            "0 0 1], baseline=, doffs=).",
        ),
        click.option(
            "--focal", type=float, default=None, help="Focal length in pixels (without --calib)."
        ),
        click.option(
            "--baseline",
            type=float,
            default=None,
            help="Baseline, in the unit the depth should have (without --calib).",
        ),
        click.option(
            "--principal",
            type=(float, float),
            default=None,
            metavar="CX CY",
            help="Principal point in pixels (without --calib; default: the image centre).",
        ),
        click.option(
            "--doffs",
            type=float,
            default=None,
            help="Principal points' x offset, right minus left, in pixels (without --calib; "
            "default 0).",
        ),
    ]
    return _option_group(func, "calibration", CALIBRATION_OPTIONS, options)


def calibration_of(options, shape, needed):
    """Return the :class:`~dcstereo.geometry.Calibration` the options give, or None.

    ``shape`` is the left image's (the default principal point is its centre); ``needed``
    whether an output uses it (calibration options with no such output, or such an output
    with no calibration, are errors).
    """
    from ..geometry import Calibration

    given = [flag for name, flag in CALIBRATION_OPTIONS.items() if options[name] is not None]
    if not needed:
        if given:
            raise CommandError(f"{given[0]} is used only with --depth-out or --ply")
        return None
    if options["calib"] is not None:
        if len(given) > 1:
            raise CommandError(f"--calib and {given[1]} cannot be used together")
        return Calibration.from_middlebury(options["calib"])
    for name in ("focal", "baseline"):
        if options[name] is None:
            raise CommandError(
                f"--depth-out and --ply need a calibration: --calib FILE, or --focal and "
                f"--baseline (missing {CALIBRATION_OPTIONS[name]})"
            )
    height, width = shape[:2]
    cx, cy = options["principal"] or ((width - 1) / 2, (height - 1) / 2)
    doffs = 0.0 if options["doffs"] is None else options["doffs"]
    return Calibration(options["focal"], options["baseline"], cx, cy, doffs)

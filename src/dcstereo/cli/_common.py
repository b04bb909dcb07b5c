"""Options and error handling shared by the subcommands."""

import contextlib
import functools
import time
from pathlib import Path

import click
from numba.core import event as numba_event

from dcstereo import params as _params
from dcstereo.params import (
    COSTS,
    DEFAULT_METHOD,
    DEFAULT_OCCLUSION_COST,
    MAX_MEDIAN,
    METHOD_DEFAULTS,
    METHOD_OPTIONS,
    METHODS,
    NAMED_MEDIANS,
    SGM_METHODS,
    SUBPIXEL_FITS,
    WEIGHTED_MEDIAN,
    WEIGHTED_PLANES,
)
from dcstereo.viz import PREVIEW_STYLES

#: Methods whose result carries feature pairs.
FEATURE_METHODS = ("dc", "dc-linear", "dsi3-gcp")

#: The keyword arguments of :func:`dcstereo.match` that :func:`matching_options` collects
#: (those not given on the command line are left out: the method's defaults apply).
MATCH_OPTIONS = ("method", "window", "cost", "fill", "subpixel", "median")

#: The two flags of the on/off options of :data:`METHOD_OPTIONS`.
_SWITCHES = {
    "vs_relative": "--vs-relative/--vs-absolute",
    "lr_check": "--lr-check/--no-lr-check",
    "planes": "--planes/--no-planes",
}


def _flag(name: str) -> str:
    """Return the command-line flag of a keyword argument (``ser_min``: ``--ser-min``)."""
    return _SWITCHES.get(name, "--" + name.replace("_", "-"))


def _slopes(ctx, param, value):
    """Parse ``--orientations`` (comma-separated slopes) into a tuple of floats."""
    if value is None:
        return None
    try:
        return tuple(float(part) for part in value.split(","))
    except ValueError:
        raise click.BadParameter(
            f"expected comma-separated slopes such as -0.5,0,0.5, got {value!r}"
        ) from None


_DEFAULT_SLOPES = ",".join(f"{v:g}" for v in _params.DEFAULT_ORIENTATIONS)


def _census_window(ctx, param, value):
    """Parse ``--census-window`` (``ROWSxCOLS`` or one odd side) into ``(rows, cols)``."""
    if value is None:
        return None
    parts = value.lower().replace(",", "x").split("x")
    try:
        sides = tuple(int(part) for part in parts)
    except ValueError:
        sides = ()
    if len(sides) == 1:
        sides = sides * 2
    if len(sides) != 2:
        raise click.BadParameter(f"expected ROWSxCOLS such as 5x5 or 7x9, got {value!r}")
    return sides


#: The methods' own parameters (keyword arguments of :func:`dcstereo.match`) that
#: :func:`matching_options` adds: each one's ``--help`` text and ``click.option`` settings
#: other than the flag and the default (None: not given, then the
#: :class:`~dcstereo.params.MatchParams` default). The methods that read each are
#: :data:`dcstereo.params.METHOD_OPTIONS`; given to a method that does not read it: an
#: error, rather than a silent no-op.
_METHOD_OPTION_TABLE = {
    "slant_cost": (
        "Extra cost of each d or e step of the five-step model, in the units of "
        "--occlusion-cost (redert: of each disparity step of a slanted segment). Default: "
        f"the method's ({_params.DEFAULT_SLANT_COST:g} for dsi5, the paper's model; "
        f"{_params.DEFAULT_DC_SLANT_COST:g} for dc).",
        {"type": float},
    ),
    "ser_min": (
        "Least signal-to-error ratio (eq. 2) of a reliable feature pair "
        f"(default {_params.DEFAULT_SER_MIN:g}).",
        {"type": float},
    ),
    "vs_max": (
        "Largest variance dissimilarity (eq. 3) of a reliable pair (default "
        f"{_params.DEFAULT_VS_MAX:g}, for the scale-free VS).",
        {"type": float},
    ),
    "vs_relative": (
        "VS scale-free, |var_L - var_R| / (var_L + var_R) (the default), or the paper's "
        "|var_L - var_R| in gray levels squared (then set --vs-max to match).",
        {},
    ),
    "feature_floor": (
        "Least window variance (gray levels squared) of a candidate feature "
        f"(default {_params.DEFAULT_FEATURE_FLOOR:g}).",
        {"type": float},
    ),
    "uniqueness": (
        "A candidate's second-least window cost (two or more disparities away) must be "
        f"at least this times its least (default {_params.DEFAULT_UNIQUENESS:g}; 0: off).",
        {"type": float},
    ),
    "edge_guard": (
        "Columns left and right of a candidate whose windows must match within one "
        "disparity of it (default: window // 2 + 1; 0: off).",
        {"type": int},
    ),
    "lr_check": (
        "Also require the right pixel of a candidate to match back to it (default: off).",
        {},
    ),
    "max_candidates": (
        "Candidates tried per interval before giving up on it (default 0: every pixel "
        "above --feature-floor).",
        {"type": int},
    ),
    "gcp_uniqueness": (
        "The ratio test of a ground control point (default "
        f"{_params.DEFAULT_GCP_UNIQUENESS:g}; 0: off).",
        {"type": float},
    ),
    "gcp_variance_floor": (
        "Least window variance of a ground control point (default "
        f"{_params.DEFAULT_GCP_VARIANCE_FLOOR:g}).",
        {"type": float},
    ),
    "occlusion_cost": (
        "Cost of one occluded pixel, in gray levels of mean absolute difference (default "
        f"{DEFAULT_OCCLUSION_COST:g}).",
        {"type": float},
    ),
    "census_window": (
        "The census window, ROWSxCOLS, odd sides, at most 64 bits "
        f"(default {_params.DEFAULT_CENSUS_WINDOW[0]}x{_params.DEFAULT_CENSUS_WINDOW[1]}).",
        {"callback": _census_window, "metavar": "ROWSxCOLS"},
    ),
    "ad_truncation": (
        "--cost census-ad: the colour difference's truncation, in gray levels of mean "
        f"absolute difference (default {_params.DEFAULT_AD_TRUNCATION}).",
        {"type": int},
    ),
    "p1": (
        "Penalty of a one-pixel disparity step between neighbours on a path, in cost units "
        f"(a census bit costs 96 / bits; default {_params.DEFAULT_P1}).",
        {"type": int},
    ),
    "p2": (
        f"Penalty of a larger disparity jump, in cost units (default {_params.DEFAULT_P2}).",
        {"type": int},
    ),
    "p2_gradient": (
        "Lower --p2 across intensity edges: p2 / (1 + |dI| / this), dI in gray levels "
        f"(default {_params.DEFAULT_P2_GRADIENT:g}; 0: a constant p2).",
        {"type": float},
    ),
    "paths": (
        f"Aggregation paths: 4 or 8 (default {_params.DEFAULT_PATHS}).",
        {
            "type": click.Choice(["4", "8"]),
            "callback": lambda c, p, v: None if v is None else int(v),
        },
    ),
    "lr_tolerance": (
        "Left-right check: the largest difference, in pixels, between a pixel's disparity "
        f"and its right pixel's (default {_params.DEFAULT_LR_TOLERANCE}; -1: no check).",
        {"type": int, "callback": lambda c, p, v: v if v is None or v >= 0 else "off"},
    ),
    "planes": (
        "After the left-right check, a robust plane per superpixel of the left image for "
        "the mismatches and the unsure estimates (default: off).",
        {},
    ),
    "census_step": (
        "Spacing of the census window's samples: 1 (the default) every pixel, 2 a sparse "
        "census twice as wide for the same bits.",
        {"type": int},
    ),
    "census_smoothing": (
        "Sigma, in pixels, of a Gaussian smoothing of each view's intensity before the "
        "census (default 0: none; 1.2 for noisy camera images such as driving scenes).",
        {"type": float},
    ),
    "photometric": (
        "Before the colour term (cost census-ad): matched maps the right view's colours "
        "onto the left's through the pixels a coarse pass matched, against a change of "
        "gain, offset or gamma between the cameras. Default: none.",
        {"type": click.Choice(list(_params.PHOTOMETRIC))},
    ),
    "row_alignment": (
        "estimated moves the right view's rows onto the left's before the costs, by the "
        "vertical offsets measured around a coarse pass's matches, for a pair whose "
        "rectification is a little off. Default: none.",
        {"type": click.Choice(list(_params.ROW_ALIGNMENTS))},
    ),
    "edges": (
        "After the median: support-weights decides the pixels near the map's depth edges "
        "again, between their value and the farther ones past the jumps around them, by "
        "adaptive support weights (indoor scenes gain, driving scenes lose a little). "
        "Default: none.",
        {"type": click.Choice(list(_params.EDGES))},
    ),
    "aggregation": (
        "A stage between the costs and the semi-global paths: cross (the costs averaged "
        "over cross-based support regions of the left view, ADCensus) or cross-both (over "
        "the regions both views share at each disparity). Default: none.",
        {"type": click.Choice(["cross", "cross-both"])},
    ),
    "cross_limit": (
        "--aggregation cross: the arms are shorter than this many pixels "
        f"(default {_params.DEFAULT_CROSS_LIMIT}).",
        {"type": int},
    ),
    "cross_tau": (
        "--aggregation cross: an arm stops at a channel difference of this many gray "
        f"levels (default {_params.DEFAULT_CROSS_TAU}).",
        {"type": int},
    ),
    "cross_iterations": (
        "--aggregation cross: rounds of a horizontal and a vertical pass "
        f"(default {_params.DEFAULT_CROSS_ITERATIONS}).",
        {"type": int},
    ),
    "orientations": (
        "Comma-separated surface slopes (px of disparity per px), each of 0, +-0.0625, "
        f"+-0.125, +-0.25, +-0.5, +-1 (default {_DEFAULT_SLOPES}).",
        {"callback": _slopes, "metavar": "SLOPES"},
    ),
    "orientation_cost": (
        "Cost of a change of orientation, in the units of --occlusion-cost "
        f"(default {_params.DEFAULT_ORIENTATION_COST:g}).",
        {"type": float},
    ),
    "occlusion_discount": (
        "Fraction of --occlusion-cost taken off the pixels of an occlusion run after its "
        f"first, in [0, 1) (default {_params.DEFAULT_OCCLUSION_DISCOUNT:g}).",
        {"type": float},
    ),
    "occlusion_discount_pixels": (
        "How many pixels of a run after its first get the discount "
        f"(default {_params.DEFAULT_OCCLUSION_DISCOUNT_PIXELS}).",
        {"type": int},
    ),
}


def _method_option_list():
    """Return the options of :data:`METHOD_OPTIONS` as ``--help`` lists them.

    In its order, each help text tagged with the methods that read the option.
    """
    return [
        click.option(
            _flag(name),
            name,
            default=None,
            help=f"[{', '.join(METHOD_OPTIONS[name])}] {text}",
            **settings,
        )
        for name, (text, settings) in _METHOD_OPTION_TABLE.items()
    ]


def describe(params) -> str:
    """One line of a run's method and main settings (``method sgm, census 5x5 + colour, ..``)."""
    if params.method in SGM_METHODS:
        rows, cols = params.census_window
        cost = f"census {rows}x{cols}" + (" + colour" if params.cost == "census-ad" else "")
        parts = [f"method {params.method}, {cost}, window {params.window}", f"P1 {params.p1}",
                 f"P2 {params.p2}", f"{params.paths} paths"]  # fmt: skip
    else:
        parts = [f"method {params.method}, window {params.window}"]
        if params.method != "block":
            parts.append(f"occlusion cost {params.occlusion_cost:g}")
        if params.cost != "sad":
            parts.append(f"cost {params.cost}")
    if params.subpixel:
        parts.append(f"sub-pixel {params.subpixel}")
    if params.median:
        parts.append(f"median {params.median}")
    return ", ".join(parts)


class CommandError(click.ClickException):
    """A one-line user-facing error (exit code 1)."""

    def show(self, file=None):
        """Print ``Error: <message>`` on one line, never a traceback."""
        click.echo(f"Error: {self.format_message()}", err=True, file=file)


def one_line_errors(func):
    """Turn the library's ValueError, TypeError, OSError, MemoryError, ImportError into one line."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except (ValueError, TypeError, OSError, MemoryError, ImportError) as exc:
            message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise CommandError(message) from None

    return wrapper


def check_output_paths(*paths):
    """Fail before any work when an output folder is missing or an output is a folder."""
    from dcstereo.io import check_writable

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
    The writer writes the temporary file directly (one level of temporary files), and
    what earlier commands killed before their rename left beside ``path`` is removed.
    """
    from dcstereo import io

    with io.atomic_writes() as stage:

        def write(writer, path, *args, **kwargs):
            io.remove_stale_temporaries(path)
            temporary = stage(path)
            try:
                return writer(temporary, *args, **kwargs)
            except (ValueError, TypeError, OSError) as exc:
                # the writer's message names the temporary file; the user knows the output
                raise ValueError(str(exc).replace(str(temporary), str(path))) from None

        yield write


#: What the commands print (on stderr) when a kernel compiles, before it does.
COMPILE_NOTICE = (
    "Compiling the kernels for this machine: about a minute, on the first run only "
    "(numba caches them on disk)."
)


class CompileWatch(numba_event.Listener):
    """Time numba's compiling inside :func:`compile_watch`, and announce its start once.

    ``seconds``: the time the outermost compiles took (a kernel's callees compile inside
    it, counted once); 0 when every kernel came from numba's cache.
    """

    def __init__(self, announce):
        self.seconds = 0.0
        self._announce = announce
        self._depth = 0
        self._start = 0.0

    def on_start(self, event):
        """Start the clock at an outermost compile (numba compiles one at a time)."""
        if self._depth == 0:
            if self._announce is not None:
                self._announce()
                self._announce = None
            self._start = time.perf_counter()
        self._depth += 1

    def on_end(self, event):
        """Stop the clock at the end of an outermost compile."""
        self._depth -= 1
        if self._depth == 0:
            self.seconds += time.perf_counter() - self._start


@contextlib.contextmanager
def compile_watch(quiet=False):
    """Watch numba compile kernels in the block: yields a :class:`CompileWatch`.

    Unless ``quiet``, the first compile prints :data:`COMPILE_NOTICE` on stderr before it
    starts, so that a first run's wait is explained; a run whose kernels are all cached
    prints nothing.
    """
    watch = CompileWatch(None if quiet else lambda: click.echo(COMPILE_NOTICE, err=True))
    with numba_event.install_listener("numba:compile", watch):
        yield watch


def compile_note(watch) -> str:
    """``" (N s of it compiling the kernels)"`` after a time that includes compiling, or ""."""
    if watch.seconds < 0.05:
        return ""
    return f" ({watch.seconds:.1f} s of it compiling the kernels)"


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

    The command receives the options named in :data:`MATCH_OPTIONS`, and those of
    :data:`METHOD_OPTIONS` that were given, as one dict, ``match_options`` (keyword
    arguments of ``match``), and ``threads`` on its own; a new matching option is added
    here once, for every command.
    """
    options = [
        click.option(
            "--method",
            type=click.Choice(METHODS),
            default=DEFAULT_METHOD,
            show_default=True,
            help="Matching method.",
        ),
        click.option(
            "--window",
            type=int,
            default=None,
            help="Odd side of the square matching window: the SAD window of the scanline "
            "methods, the box averaging sgm's costs (default: "
            f"{METHOD_DEFAULTS[None]['window']}; sgm {METHOD_DEFAULTS['sgm']['window']}).",
        ),
        click.option(
            "--cost",
            type=click.Choice(COSTS),
            default=None,
            help="Matching cost: windowed SAD (the paper's eq. 4) or Birchfield-Tomasi for the "
            "scanline methods (default sad); census or census-ad (census plus a truncated "
            "colour difference) for sgm (default census-ad).",
        ),
        click.option(
            "--fill/--no-fill",
            default=None,
            help="Fill the pixels without an estimate (dense map; default: on for sgm, off "
            "for the others).",
        ),
        click.option(
            "--subpixel",
            type=click.Choice([*SUBPIXEL_FITS, "none"]),
            default=None,
            help="Refine each whole-pixel disparity to a fraction of a pixel by this fit "
            "through the costs at d - 1, d, d + 1 (sgm: its aggregated costs; before "
            "--fill; default: equiangular for sgm, none for the others).",
        ),
        median_option,
        click.option(
            "--threads",
            type=int,
            default=None,
            help="Number of threads (default: all cores).",
        ),
    ]

    @functools.wraps(func)
    def with_method_options(*args, method_options, **kwargs):
        # the methods' own options join match_options where given, for a method that reads
        # them
        check_method_options(method_options, [kwargs["match_options"]["method"]])
        kwargs["match_options"].update(method_options)
        kwargs["match_options"] = {
            k: v for k, v in kwargs["match_options"].items() if v is not None
        }
        return func(*args, **kwargs)

    return _option_group(
        add_method_options(with_method_options), "match_options", MATCH_OPTIONS, options
    )


def add_method_options(func):
    """Add each method's own parameters (:data:`METHOD_OPTIONS`) to the command ``func``.

    The command receives those given as one dict, ``method_options`` (keyword arguments of
    :func:`dcstereo.match`); :func:`check_method_options` refuses one that none of the
    methods run reads.
    """

    @functools.wraps(func)
    def collect(*args, **kwargs):
        given = {name: kwargs.pop(name) for name in METHOD_OPTIONS}
        given = {k: v for k, v in given.items() if v is not None}
        if given.get("lr_tolerance") == "off":  # -1 on the command line: no check
            given["lr_tolerance"] = None
        kwargs["method_options"] = given
        return func(*args, **kwargs)

    for option in reversed(_method_option_list()):
        collect = option(collect)
    return collect


def check_method_options(given, methods):
    """Refuse (a one-line error) an option of ``given`` that none of ``methods`` reads.

    ``methods`` are dcstereo method names, with or without a ``+bt`` suffix, and others
    (OpenCV's), which read none. :func:`dcstereo.params.check_method_options`, with the
    options named by their flags.
    """
    try:
        _params.check_method_options(given, methods, label=_flag)
    except ValueError as exc:
        raise CommandError(str(exc)) from None


class MedianType(click.ParamType):
    """``--median``: an integer window side or a named median (checked by the match's options)."""

    name = "K|" + "|".join(NAMED_MEDIANS)

    def convert(self, value, param, ctx):
        if isinstance(value, int) or value in NAMED_MEDIANS:
            return value
        try:
            return int(value)
        except ValueError:
            names = " nor ".join(repr(n) for n in NAMED_MEDIANS)
            self.fail(f"{value!r} is neither an integer nor {names}", param, ctx)


#: ``--median K|weighted|weighted-planes``: the post-filter of
#: :mod:`dcstereo.refine.postfilter`, :mod:`dcstereo.refine.weighted_median` or that and
#: :mod:`dcstereo.refine.local_planes`.
median_option = click.option(
    "--median",
    type=MedianType(),
    default=None,
    help="Median post-filter: every estimate but the feature pairs' takes the median of "
    f"the estimates in this odd square around it, 3 to {MAX_MEDIAN} (after --subpixel, "
    f"before --fill, sgm: after its fill; 0: off; default {METHOD_DEFAULTS['sgm']['median']} "
    f"for sgm, {METHOD_DEFAULTS['sgm-accurate']['median']} for sgm-accurate, 0 for the "
    f"others); {WEIGHTED_MEDIAN}: the median of a 9 x 9 square weighted "
    "by the left image's colours and the distance (depth edges stay on colour edges); "
    f"{WEIGHTED_PLANES}: that, then each estimate the value of a plane fitted to the "
    "estimates of its 9 x 9 square within a pixel of it, weighted alike (slanted surfaces).",
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


def rerun_options(func):
    """Add ``--rerun FILE.rrd`` and ``--rerun-spawn``: the result in the Rerun viewer."""
    func = click.option(
        "--rerun-spawn",
        is_flag=True,
        help="Start a Rerun viewer and stream the result to it (needs dcstereo[rerun]).",
    )(func)
    return click.option(
        "--rerun",
        "rerun_out",
        type=click.Path(dir_okay=False),
        default=None,
        metavar="FILE.rrd",
        help="Save a Rerun recording: the left image, the disparity, the occlusion and "
        "confidence maps and, with a calibration, the camera, the depth and the coloured "
        "point cloud, each frame at its index on the time line 'frame' (open it with: "
        "rerun FILE.rrd; needs dcstereo[rerun]).",
    )(func)


def check_rerun():
    """Fail at once (one line, the extra named) when rerun-sdk is not installed."""
    from dcstereo.viz import _import_rerun

    try:
        _import_rerun()
    except ImportError as exc:
        raise CommandError(f"--rerun and --rerun-spawn need Rerun: {exc}") from None


def record_rerun(path, *, spawn, result, left, camera, sure, frame=0):
    """Log one result to a Rerun recording saved at ``path`` and/or a spawned viewer."""
    from dcstereo.viz import log_rerun, rerun_recording

    with rerun_recording(path, spawn=spawn) as recording:
        log_rerun(
            result, left, recording=recording, calibration=camera, confidence=sure, frame=frame
        )


def calibration_of(options, shape, needed):
    """Return the :class:`~dcstereo.geometry.Calibration` the options give, or None.

    ``shape`` is the left image's (the default principal point is its centre); ``needed``
    whether an output uses it (calibration options with no such output, or such an output
    with no calibration, are errors).
    """
    from dcstereo.geometry import Calibration

    given = [flag for name, flag in CALIBRATION_OPTIONS.items() if options[name] is not None]
    if not needed:
        if given:
            raise CommandError(f"{given[0]} is used only with --depth-out, --ply or --rerun")
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

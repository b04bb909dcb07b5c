"""A method is data: a name and an ordered list of named stages, each a function of arrays.

Every stage takes the pair, the validated :class:`~dcstereo.params.MatchParams` and the
result of the stages before it (None for the first) and returns the new result. A stage
whose option is off (``when``) is skipped. A fused stage runs several steps of the data
path in one pass (``sgm``'s costs, paths, choice and left-right check share one sweep over
the volume); its name lists them, and its tests compare it with the plain steps. A stage
that needs an intermediate of an earlier one, not the result (``sgm``'s edges stage, the
views its costs compared), finds it in the store the stages of a run share
(``run_shared()``), which ends with the run.

>>> from dcstereo.methods import REGISTRY
>>> print(REGISTRY["dsi5"])
dsi5: dsi5 [costs (SAD or BT, eq. 4) + five-step DP (eq. 5)] -> subpixel -> median -> fill
"""

import contextvars
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from dcstereo._threads import threads_with_cores
from dcstereo.params import WEIGHTED_MEDIAN, WEIGHTED_PLANES, MatchParams
from dcstereo.refine.local_planes import local_plane_filter
from dcstereo.refine.postfilter import median_filter
from dcstereo.refine.subpixel import refine_subpixel
from dcstereo.refine.weighted_median import weighted_median_filter
from dcstereo.result import DisparityResult

StageFunction = Callable[
    [np.ndarray, np.ndarray, MatchParams, DisparityResult | None], DisparityResult
]


def _always(params: MatchParams) -> bool:
    return True


#: What the stages of the :meth:`Method.run` in progress share (a dict, None outside a
#: run): a stage that needs an intermediate of an earlier one (``sgm``'s edges stage, the
#: views its costs compared) finds it here, and it goes when the run ends.
_RUN = contextvars.ContextVar("dcstereo_run", default=None)


def run_shared() -> dict | None:
    """Return the values the stages of the current :meth:`Method.run` share (None outside)."""
    return _RUN.get()


@dataclass(frozen=True)
class Stage:
    """One named step of a method: ``run(left, right, params, result) -> result``.

    ``when(params)`` says whether it runs (its option is on); ``steps`` names what a fused
    stage does, in the order of the data path.
    """

    name: str
    run: StageFunction
    when: Callable[[MatchParams], bool] = _always
    steps: str = ""

    def __str__(self) -> str:
        return f"{self.name} [{self.steps}]" if self.steps else self.name


def option(name: str):
    """Return a record field with :class:`~dcstereo.MatchParams`' default for ``name``.

    The defaults are stated once, in :class:`~dcstereo.MatchParams` (and the constants of
    :mod:`dcstereo.params` it reads); a method's record takes them from there.
    """
    return field(default=MatchParams.__dataclass_fields__[name].default)


@dataclass(frozen=True, kw_only=True)
class MethodParams:
    """What every method reads: the range, the window, the cost and the refinement.

    A method's record (:class:`~dcstereo.methods.sgm.SGMParams`, ...) adds the options that
    method reads, and nothing else: an option of another method is a ``TypeError`` by
    construction. ``None`` takes the method's default (:data:`dcstereo.params.METHOD_DEFAULTS`),
    resolved when the record is made; every value is checked as :class:`~dcstereo.MatchParams`
    checks it (the one place the checks are written).
    """

    #: The method the record is for (a class constant, not a field).
    METHOD = ""

    max_disparity: int
    min_disparity: int = 0
    window: int | None = None
    cost: str | None = None
    fill: bool | None = None
    subpixel: str | None = None
    median: int | None = None

    def __post_init__(self):
        resolved = self.match_params()
        for name in (f.name for f in fields(self)):
            object.__setattr__(self, name, getattr(resolved, name))

    def match_params(self) -> MatchParams:
        """Return the flat :class:`~dcstereo.MatchParams` of this record (validated)."""
        return MatchParams(method=self.METHOD, **asdict(self))


@dataclass(frozen=True)
class Method:
    """A method of :func:`dcstereo.match`: its name and its stages, run in order."""

    name: str
    stages: tuple[Stage, ...]
    summary: str = ""
    #: The method's parameter record (a ``MethodParams``: :class:`dcstereo.SGMParams`, ...).
    params: type | None = None

    def run(self, left: np.ndarray, right: np.ndarray, params: MatchParams) -> DisparityResult:
        """Run the stages whose options are on; the pair and ``params`` already validated.

        The stages share a fresh ``run_shared()`` dict, dropped when the run ends.
        """
        token = _RUN.set({})
        try:
            result = None
            for stage in self.stages:
                if stage.when(params):
                    result = stage.run(left, right, params, result)
            return result
        finally:
            _RUN.reset(token)

    def stage_names(self) -> tuple[str, ...]:
        """Return the names of the stages, in order."""
        return tuple(stage.name for stage in self.stages)

    def __str__(self) -> str:
        return f"{self.name}: " + " -> ".join(str(stage) for stage in self.stages)


def core(name: str, function, steps: str) -> Stage:
    """Return the first stage of a method: ``function(left, right, params)`` makes the map."""
    return Stage(
        name, lambda left, right, params, result: function(left, right, params), steps=steps
    )


#: Sub-pixel refinement of whole-pixel estimates (``subpixel``), before the median and fill.
SUBPIXEL = Stage(
    "subpixel",
    lambda left, right, params, result: refine_subpixel(result, left, right, fit=params.subpixel),
    when=lambda params: params.subpixel is not None,
)


def median_post_filter(result: DisparityResult, left: np.ndarray, median: int | str):
    """Return ``result`` through the median post-filter that ``median`` names.

    An odd window side: :func:`~dcstereo.refine.postfilter.median_filter`; ``"weighted"``:
    :func:`~dcstereo.refine.weighted_median.weighted_median_filter`, guided by ``left``;
    ``"weighted-planes"``: that, then
    :func:`~dcstereo.refine.local_planes.local_plane_filter`. The one place they are chosen
    (``match``'s stage and ``match_tiled``'s stitched map).
    """
    if median == WEIGHTED_MEDIAN:
        return weighted_median_filter(result, left)
    if median == WEIGHTED_PLANES:
        return local_plane_filter(weighted_median_filter(result, left), left)
    return median_filter(result, median)


#: The median post-filter (``median``): each estimate takes its window's median, plain or
#: weighted by the left image's colours (``median="weighted"``, and ``"weighted-planes"``
#: with a plane per pixel after it): :func:`median_post_filter`.
def _median(left, right, params, result):
    with threads_with_cores():  # as sgm's own stages: the threads that have a core
        return median_post_filter(result, left, params.median)


MEDIAN = Stage("median", _median, when=lambda params: bool(params.median))

#: The fill (``fill``): pixels still without an estimate take the background disparity.
FILL = Stage(
    "fill",
    lambda left, right, params, result: result.filled(),
    when=lambda params: params.fill,
)

#: The refinement every method of the paper ends with.
REFINE = (SUBPIXEL, MEDIAN, FILL)

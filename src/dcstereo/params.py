"""Frozen, validated parameters of :func:`dcstereo.match`."""

import math
from dataclasses import dataclass

#: Methods understood by :func:`dcstereo.match`, in the order the docs present them.
METHODS = ("dc", "dc-linear", "dsi5", "dsi3", "block")

#: Default occlusion cost per pixel, in gray levels of mean absolute difference.
DEFAULT_OCCLUSION_COST = 10.0

#: Reliability defaults of the divide-and-conquer methods (see docs for how they were chosen).
DEFAULT_SER_MIN = 2.0
DEFAULT_VS_MAX = 0.2
DEFAULT_FEATURE_FLOOR = 400.0


@dataclass(frozen=True)
class MatchParams:
    """Parameters of one matching run.

    Parameters
    ----------
    max_disparity, min_disparity : int
        Inclusive search range, in pixels: a left pixel ``x`` may match right pixels
        ``x - max_disparity .. x - min_disparity``.
    method : str
        One of :data:`METHODS`.
    window : int
        Odd side ``W`` of the square SAD window of eq. 4.
    occlusion_cost : float
        ``C_occ`` of eq. 5 per occluded pixel, in the units of the per-pixel absolute
        difference on the 0..255 intensity scale (the window cost is the *mean* absolute
        difference), so one value means the same thing for every window size.
    fill : bool
        Fill pixels without an estimate with the background disparity (see
        :func:`dcstereo.fill_occlusions`).
    ser_min : float
        ``dc`` methods: smallest signal-to-error ratio (eq. 2) of a reliable feature pair,
        ``(var_L + var_R) / sum_window (I_L - I_R)^2``.
    vs_max : float
        ``dc`` methods: largest variance dissimilarity (eq. 3) of a reliable pair.
    vs_relative : bool
        Use the scale-free ``|var_L - var_R| / (var_L + var_R)`` (in ``[0, 1]``) instead of
        the paper's ``|var_L - var_R|`` (gray levels squared).
    feature_floor : float
        Candidates stop at this window variance (gray levels squared): flatter pixels are
        never tried as features.
    max_candidates : int
        Candidates tried per interval before giving up on it; 0 tries every pixel above the
        floor.
    lr_check : bool
        Also require the right pixel of a candidate pair to choose the same left pixel when
        block-matched back inside the interval (a left-right consistency test; not in the
        paper, which relies on SER and VS alone).
    """

    max_disparity: int
    min_disparity: int = 0
    method: str = "dc"
    window: int = 5
    occlusion_cost: float = DEFAULT_OCCLUSION_COST
    fill: bool = False
    slant_cost: float = 0.0
    ser_min: float = DEFAULT_SER_MIN
    vs_max: float = DEFAULT_VS_MAX
    vs_relative: bool = True
    feature_floor: float = DEFAULT_FEATURE_FLOOR
    max_candidates: int = 0
    lr_check: bool = True

    def __post_init__(self):
        for name in ("max_disparity", "min_disparity", "window", "max_candidates"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                if isinstance(value, float) and value.is_integer():
                    object.__setattr__(self, name, int(value))
                else:
                    raise TypeError(f"{name} must be an integer, got {value!r}")
        if self.min_disparity > self.max_disparity:
            raise ValueError(
                f"min_disparity={self.min_disparity} is larger than "
                f"max_disparity={self.max_disparity}"
            )
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose one of {', '.join(METHODS)}")
        if self.window < 1 or self.window % 2 == 0:
            raise ValueError(f"window must be a positive odd integer, got {self.window}")
        cost = self.occlusion_cost
        if isinstance(cost, bool) or not isinstance(cost, (int, float)) or not math.isfinite(cost):
            raise ValueError(f"occlusion_cost must be a finite number, got {cost!r}")
        if cost <= 0:
            raise ValueError(f"occlusion_cost must be positive, got {cost}")
        for name in ("ser_min", "vs_max", "feature_floor", "slant_cost"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
            if math.isnan(value):
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
        if self.max_candidates < 0:
            raise ValueError(
                f"max_candidates must be 0 (no limit) or positive, got {self.max_candidates}"
            )

    @property
    def num_disparities(self) -> int:
        """Number of disparities searched (``max - min + 1``)."""
        return self.max_disparity - self.min_disparity + 1

    def check_image_size(self, height: int, width: int) -> None:
        """Raise ``ValueError`` when the range or the window does not fit a (H, W) image."""
        if self.max_disparity >= width:
            raise ValueError(
                f"max_disparity={self.max_disparity} does not fit an image {width} pixels wide "
                f"(it must be at most {width - 1})"
            )
        if self.min_disparity <= -width:
            raise ValueError(
                f"min_disparity={self.min_disparity} does not fit an image {width} pixels wide "
                f"(it must be at least {-(width - 1)})"
            )
        if self.window > min(height, width):
            raise ValueError(
                f"window={self.window} is larger than the image ({height} x {width} pixels)"
            )

"""Frozen, validated parameters of :func:`dcstereo.match`."""

import math
from dataclasses import dataclass

#: Methods understood by :func:`dcstereo.match`, in the order the docs present them.
METHODS = ("block", "dsi3", "dsi5")

#: Default occlusion cost per pixel, in gray levels of mean absolute difference.
DEFAULT_OCCLUSION_COST = 20.0


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
    """

    max_disparity: int
    min_disparity: int = 0
    method: str = "dsi5"
    window: int = 5
    occlusion_cost: float = DEFAULT_OCCLUSION_COST
    fill: bool = False

    def __post_init__(self):
        for name in ("max_disparity", "min_disparity", "window"):
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

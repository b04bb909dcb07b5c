"""The checks of the options of ``sgm`` and ``redert``, called by :class:`~dcstereo.MatchParams`.

Each takes the record being made (its method's defaults already filled in), raises
``ValueError`` or ``TypeError`` naming the option and the value, and writes back the
normalised values (``(rows, cols)`` tuples, Python ints and floats).
"""

import math

import numpy as np

from dcstereo._checks import is_integer, is_number
from dcstereo.params import (
    AGGREGATIONS,
    EDGES,
    MAX_CENSUS_BITS,
    MAX_CENSUS_SMOOTHING,
    MAX_OCCLUSION_DISCOUNT_PIXELS,
    PHOTOMETRIC,
    ROW_ALIGNMENTS,
    SGM_METHODS,
)


def check_semi_global(params) -> None:
    """Validate ``sgm``'s options (census window, truncation, penalties, paths, stages)."""
    window = params.census_window
    if (
        not isinstance(window, (tuple, list))
        or len(window) != 2
        or not all(is_integer(v) for v in window)
    ):
        raise ValueError(f"census_window must be (rows, cols), two odd integers, got {window!r}")
    rows, cols = (int(v) for v in window)
    if rows < 1 or cols < 1 or rows % 2 == 0 or cols % 2 == 0:
        raise ValueError(f"census_window must hold two odd positive integers, got {window!r}")
    if not 2 <= rows * cols - 1 <= MAX_CENSUS_BITS:
        raise ValueError(
            f"census_window={window!r} gives {rows * cols - 1} bits; a census takes "
            f"2 to {MAX_CENSUS_BITS} (for example (5, 5), (7, 7), (7, 9))"
        )
    object.__setattr__(params, "census_window", (rows, cols))
    for name, lowest in (("ad_truncation", 0), ("p1", 0), ("p2", 0), ("paths", 4)):
        value = getattr(params, name)
        if isinstance(value, float) and value.is_integer():
            value = int(value)
            object.__setattr__(params, name, value)
        if not is_integer(value) or value < lowest:
            raise ValueError(f"{name} must be an integer of at least {lowest}, got {value!r}")
    if params.paths not in (4, 8):
        raise ValueError(f"paths must be 4 or 8, got {params.paths}")
    if params.p2 < params.p1:
        raise ValueError(f"p2 ({params.p2}) must be at least p1 ({params.p1})")
    if params.ad_truncation > 255:
        raise ValueError(
            f"ad_truncation must be at most 255 gray levels, got {params.ad_truncation}"
        )
    gradient = params.p2_gradient
    if not is_number(gradient) or not math.isfinite(gradient) or gradient < 0:
        raise ValueError(f"p2_gradient must be a non-negative number, got {gradient!r}")
    for name, choices in (
        ("aggregation", AGGREGATIONS),
        ("photometric", PHOTOMETRIC),
        ("row_alignment", ROW_ALIGNMENTS),
        ("edges", EDGES),
    ):  # the stages on request: None (off) or one of their names
        value = getattr(params, name)
        if value is not None and value not in choices:
            raise ValueError(f"{name} must be None or one of {', '.join(choices)}, got {value!r}")
    if (
        params.photometric is not None
        and params.method in SGM_METHODS
        and params.cost != "census-ad"
    ):
        raise ValueError(  # other methods: refused as an option they do not read
            f"photometric={params.photometric!r} aligns the colour term's colours: it "
            f"needs cost='census-ad', got cost={params.cost!r}"
        )
    sigma = params.census_smoothing
    if not is_number(sigma) or not math.isfinite(sigma):
        raise ValueError(f"census_smoothing must be a number of pixels, got {sigma!r}")
    if not 0 <= sigma <= MAX_CENSUS_SMOOTHING:
        raise ValueError(
            f"census_smoothing must be from 0 to {MAX_CENSUS_SMOOTHING:g} pixels, got {sigma!r}"
        )
    object.__setattr__(params, "census_smoothing", float(sigma))
    for name, lowest, highest in (
        ("cross_limit", 1, 1024),
        ("cross_tau", 1, 256),
        ("cross_iterations", 1, 8),
        ("census_step", 1, 4),
    ):
        value = getattr(params, name)
        if not is_integer(value) or not lowest <= value <= highest:
            raise ValueError(f"{name} must be an integer from {lowest} to {highest}, got {value!r}")
        object.__setattr__(params, name, int(value))
    tolerance = params.lr_tolerance
    if tolerance is not None:
        if isinstance(tolerance, float) and tolerance.is_integer():
            tolerance = int(tolerance)
            object.__setattr__(params, "lr_tolerance", tolerance)
        if not is_integer(tolerance) or tolerance < 0:
            raise ValueError(
                f"lr_tolerance must be None (no check) or a non-negative integer, got {tolerance!r}"
            )


def check_redert(params) -> None:
    """Validate ``redert``'s options (orientations, their cost, the discount)."""
    values = params.orientations
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"orientations must be a sequence of slopes, got {values!r}")
    values = tuple(v.item() if isinstance(v, np.generic) else v for v in values)
    if not values:
        raise ValueError("orientations must hold at least one slope, got an empty sequence")
    for value in values:
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or abs(value) not in (0, 0.0625, 0.125, 0.25, 0.5, 1)
        ):
            raise ValueError(
                "orientations must be slopes from 0, +-0.0625, +-0.125, +-0.25, +-0.5, "
                f"+-1 (px of disparity per px), got {value!r}"
            )
    if len(set(values)) != len(values):
        raise ValueError(f"orientations must not repeat a slope, got {values!r}")
    object.__setattr__(params, "orientations", tuple(float(v) for v in values))
    cost = params.orientation_cost
    if isinstance(cost, bool) or not isinstance(cost, (int, float)) or not cost >= 0:
        raise ValueError(f"orientation_cost must be a non-negative number, got {cost!r}")
    if not math.isfinite(cost):
        raise ValueError(f"orientation_cost must be finite, got {cost!r}")
    share = params.occlusion_discount
    if isinstance(share, bool) or not isinstance(share, (int, float)) or not 0 <= share < 1:
        raise ValueError(f"occlusion_discount must be a number in [0, 1), got {share!r}")
    count = params.occlusion_discount_pixels
    if isinstance(count, float) and count.is_integer():
        count = int(count)
        object.__setattr__(params, "occlusion_discount_pixels", count)
    if isinstance(count, bool) or not isinstance(count, int):
        raise TypeError(f"occlusion_discount_pixels must be an integer, got {count!r}")
    if not 0 <= count <= MAX_OCCLUSION_DISCOUNT_PIXELS:
        raise ValueError(
            f"occlusion_discount_pixels must be 0 to {MAX_OCCLUSION_DISCOUNT_PIXELS}, got {count}"
        )

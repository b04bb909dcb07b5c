"""dcstereo: dense stereo disparity with explicit occlusions.

The method of Tsai and Katsaggelos, *Dense Disparity Estimation via Global and Local
Matching*: divide-and-conquer feature matching and an extended five-step
disparity-space dynamic program, with the baselines it is compared with.

Convention: a left pixel ``(x, y)`` matches the right pixel ``(x - d, y)``, ``d >= 0``.
"""

from . import _memory  # noqa: F401  (sets the allocator's thresholds once; see there)
from .api import match
from .params import DEFAULT_METHOD, METHODS, MatchParams
from .rectification import RectifiedPair, StereoCalibration, read_calibration, rectify
from .result import (
    FLAG_BORDER,
    FLAG_FEATURE,
    FLAG_FILLED,
    FLAG_MISMATCH,
    FLAG_OCCLUDED,
    DisparityResult,
    fill_occlusions,
)
from .stereo_dc import StereoDC

__all__ = [
    "FLAG_BORDER",
    "FLAG_FEATURE",
    "FLAG_FILLED",
    "FLAG_MISMATCH",
    "FLAG_OCCLUDED",
    "DEFAULT_METHOD",
    "METHODS",
    "DisparityResult",
    "MatchParams",
    "RectifiedPair",
    "StereoCalibration",
    "StereoDC",
    "fill_occlusions",
    "match",
    "read_calibration",
    "rectify",
]
__version__ = "0.1.0"

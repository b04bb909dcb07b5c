"""dcstereo: dense stereo disparity with explicit occlusions.

:func:`match` turns a rectified pair into a :class:`DisparityResult`: a disparity map with
the reason each pixel has no estimate (occluded, mismatched, border). Its default method,
``sgm``, is an accurate modern pipeline: census and colour costs, semi-global aggregation
along eight paths, a left-right check, an edge-aware fill, a median and a sub-pixel fit.
The method of Tsai and Katsaggelos, *Dense Disparity Estimation via Global and Local
Matching* (``dc``: divide-and-conquer feature matching and an extended five-step
disparity-space DP), is kept exact beside it, with the paper's baselines.

The package follows the data path: :mod:`dcstereo.signal`, :mod:`dcstereo.costs`,
:mod:`dcstereo.aggregate`, :mod:`dcstereo.scanline`, :mod:`dcstereo.divide`,
:mod:`dcstereo.refine`, the methods made of them (:mod:`dcstereo.methods`), then
:mod:`dcstereo.io`, :mod:`dcstereo.evaluation`, :mod:`dcstereo.viz`, :mod:`dcstereo.batch`,
:mod:`dcstereo.compat` and the command line.

Convention: a left pixel ``(x, y)`` matches the right pixel ``(x - d, y)``, ``d >= 0``.
"""

# numba's cache locator first: every kernel compiled with cache=True in this package is
# stamped with the hash of all its sources (see dcstereo._vector._cache)
from dcstereo._vector._cache import install_locator

install_locator()

from dcstereo.api import match
from dcstereo.compat.stereo_dc import StereoDC
from dcstereo.methods.block import BlockParams
from dcstereo.methods.dc import DCLinearParams, DCParams
from dcstereo.methods.dsi import DSI3Params, DSI5Params
from dcstereo.methods.gcp import GCPParams
from dcstereo.methods.redert import RedertParams
from dcstereo.methods.sgm import SGMAccurateParams, SGMParams
from dcstereo.params import DEFAULT_METHOD, METHODS, MatchParams
from dcstereo.rectification import RectifiedPair, StereoCalibration, read_calibration, rectify
from dcstereo.result import (
    FLAG_BORDER,
    FLAG_FEATURE,
    FLAG_FILLED,
    FLAG_MISMATCH,
    FLAG_OCCLUDED,
    DisparityResult,
    fill_occlusions,
)

__all__ = [
    "BlockParams",
    "DCLinearParams",
    "DCParams",
    "DSI3Params",
    "DSI5Params",
    "GCPParams",
    "RedertParams",
    "SGMAccurateParams",
    "SGMParams",
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

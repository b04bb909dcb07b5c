"""The optional layers' dependencies: imported when used, refused in one line when missing.

``pip install dcstereo`` brings numpy, numba and llvmlite (the kernels), Pillow (images),
click and rich (the command line). The rest belongs to the layer that uses it, as an extra:

========== ====================== ==========================================================
extra      package                used by
========== ====================== ==========================================================
``dask``   ``distributed``        batches and sequences on a Dask cluster (``scheduler=``)
``video``  ``imageio-ffmpeg``     reading and writing video files (an ffmpeg binary inside)
``plot``   ``matplotlib``         colour maps (``colorize``, colour previews) and figures
``data``   ``pooch``              downloading the Middlebury scenes (``dcstereo datasets``)
``opencv`` ``opencv-python``      OpenCV's baselines, rectification
``rerun``  ``rerun-sdk``          the Rerun viewer
========== ====================== ==========================================================
"""

import importlib
from types import ModuleType


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the extra to install."""


def require(module: str, extra: str, purpose: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingExtraError` naming dcstereo's ``extra``.

    >>> require("numpy", "core", "the kernels").__name__
    'numpy'
    >>> require("no_such_module_here", "plot", "colour maps")
    Traceback (most recent call last):
    ...
    dcstereo._extras.MissingExtraError: colour maps need no_such_module_here, in dcstereo's 'plot' extra: pip install "dcstereo[plot]"
    """  # noqa: E501
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(
            f"{purpose} need {module}, in dcstereo's '{extra}' extra: "
            f'pip install "dcstereo[{extra}]"'
        ) from None

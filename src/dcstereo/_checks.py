"""Type predicates of the argument checks: one meaning of "an integer" and "a number".

NumPy's scalar types count (``np.int64(5)``, ``np.float32(0.5)``: NumPy registers them
with :mod:`numbers`), booleans do not (``True`` is an ``int`` to Python, a typo to us).
And one check of a disparity map handed to the modules after the matcher (viz, geometry).
"""

import numbers

import numpy as np


def is_integer(value) -> bool:
    """Whether ``value`` is an integer: a Python or NumPy integer, not a boolean."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def is_number(value) -> bool:
    """Whether ``value`` is a real number: a Python or NumPy integer or float, not a boolean."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def disparity_array(disparity, name: str = "disparity") -> np.ndarray:
    """Return ``disparity`` as a float64 ``(H, W)`` array, or raise naming ``name``.

    Integers and floats are accepted, booleans and other dtypes are not (``TypeError``);
    anything but two dimensions is a ``ValueError``.
    """
    d = np.asarray(disparity)
    if d.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {d.dtype}")
    if d.ndim != 2:
        raise ValueError(f"{name} must be 2-D (H, W), got shape {d.shape}")
    return d.astype(np.float64)

"""The readers' and writers' shared checks of a path and of an array."""

import os
from pathlib import Path

import numpy as np


def _check_readable(path: str | os.PathLike, what: str) -> None:
    p = Path(path)
    if not p.exists():
        raise ValueError(f"cannot read {what} '{path}': file does not exist")
    if not p.is_file():
        raise ValueError(f"cannot read {what} '{path}': not a regular file")


def _as_real_array(array: np.ndarray, name: str) -> np.ndarray:
    array = np.asarray(array)
    if array.dtype.kind not in "biuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {array.dtype}")
    return array

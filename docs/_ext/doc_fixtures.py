"""What the documentation's examples expect to find: a small stereo pair on disk.

``make doctest`` runs every example of the pages in one folder that
:func:`make_example_folder` fills once per process: ``left.png`` and ``right.png``, a
rectified pair (a random texture, the right view the left shifted by 12 pixels, an object
nearer the camera at 20 pixels), and ``calib.txt`` with the calibration of Middlebury's
Motorcycle pair as scikit-image gives it.
"""

import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

CALIB = """cam0=[994.978 0 311.193; 0 994.978 254.877; 0 0 1]
cam1=[994.978 0 342.279; 0 994.978 254.877; 0 0 1]
doffs=31.086
baseline=193.001
width=741
height=497
ndisp=270
"""

_FOLDER = None


def example_pair(height=48, width=96, background=12, near=20, seed=3):
    """Return ``left, right``: uint8 views of a textured plane and a nearer square."""
    rng = np.random.default_rng(seed)
    texture = rng.integers(0, 256, (height, width + near), dtype=np.uint8)
    right = texture[:, :width].copy()
    left = np.empty_like(right)
    left[:, background:] = right[:, : width - background]
    left[:, :background] = rng.integers(0, 256, (height, background))
    top, side = height // 4, width // 2
    square = rng.integers(0, 256, (height // 2, side // 2), dtype=np.uint8)
    x_left = side
    left[top : top + square.shape[0], x_left : x_left + square.shape[1]] = square
    right[top : top + square.shape[0], x_left - near : x_left - near + square.shape[1]] = square
    return left, right


def make_example_folder() -> Path:
    """Return a temporary folder holding the examples' files, made once per process."""
    global _FOLDER
    if _FOLDER is None:
        _FOLDER = Path(tempfile.mkdtemp(prefix="dcstereo-doctest-"))
        left, right = example_pair()
        Image.fromarray(left).save(_FOLDER / "left.png")
        Image.fromarray(right).save(_FOLDER / "right.png")
        (_FOLDER / "calib.txt").write_text(CALIB)
    return _FOLDER

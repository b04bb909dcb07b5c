"""A synthetic stereo sequence with ground truth: a textured object moving over a slanted floor.

The scene, in the left camera's geometry:

* a *background*: a seeded random texture on a plane whose disparity grows by rows, from
  ``background_disparity[0]`` at the top to ``background_disparity[1]`` at the bottom
  (integer per row: a floor seen from above);
* a *foreground*: an elliptical object at disparity ``foreground_disparity`` with its own
  seeded texture, which moves from left to right, bobs up and down and turns about its
  centre from frame to frame (the texture turns with it).

The left view samples the scene directly. The right view is rendered by *forward
warping*: every left pixel ``(x, y)`` is moved to ``(x - d, y)`` in the right view in
order of increasing disparity, so where two land on the same right pixel the nearer one
(larger disparity) wins, like a z-buffer. Right pixels that no left pixel reaches (seen
only by the right camera: background uncovered beside the object, the right image's
right border) are rendered from the scene. Ground truth is the left disparity, NaN at the
left pixels that are hidden in the right view (overwritten by a nearer surface, or
falling off the right image's left edge): the convention ``x_right = x_left - d``.
"""

from dataclasses import dataclass

import numpy as np

from dcstereo._checks import is_integer, is_number


@dataclass(frozen=True)
class SyntheticFrame:
    """One frame of :func:`synthetic_sequence`.

    Attributes
    ----------
    left, right : ndarray of uint8, shape (H, W)
        The rectified pair.
    disparity : ndarray of float32, shape (H, W)
        Ground-truth disparity of the left view (integers), NaN where the left pixel is
        not visible in the right view.
    foreground : ndarray of bool, shape (H, W)
        Left pixels on the moving object.
    """

    left: np.ndarray
    right: np.ndarray
    disparity: np.ndarray
    foreground: np.ndarray


def synthetic_sequence(
    n_frames: int,
    *,
    height: int = 96,
    width: int = 128,
    background_disparity: tuple[int, int] = (2, 6),
    foreground_disparity: int = 14,
    turn: float = 0.12,
    seed: int = 0,
) -> list[SyntheticFrame]:
    """Render a seeded synthetic stereo sequence with ground-truth disparity.

    Parameters
    ----------
    n_frames : int
        Number of frames (at least 1).
    height, width : int
        Frame size in pixels (at least 4 x 16).
    background_disparity : (int, int)
        Disparity of the background plane at the top and the bottom row (0 or more).
    foreground_disparity : int
        Disparity of the moving object; must exceed the background's and be less than
        half the width.
    turn : float
        Rotation of the object between frames, in radians (finite).
    seed : int
        Seed of the textures (0 or more); the same arguments give the same frames.

    Returns
    -------
    list of SyntheticFrame

    Examples
    --------
    >>> frames = synthetic_sequence(3, height=32, width=48)
    >>> frames[0].left.shape, frames[0].left.dtype
    ((32, 48), dtype('uint8'))
    >>> int(np.nanmax(frames[0].disparity))
    14
    """
    if not (isinstance(background_disparity, tuple | list) and len(background_disparity) == 2):
        raise TypeError(
            f"background_disparity must be a pair of integers (top, bottom), got "
            f"{background_disparity!r}"
        )
    top, bottom = background_disparity
    for name, value in (
        ("n_frames", n_frames),
        ("height", height),
        ("width", width),
        ("background_disparity", top),
        ("background_disparity", bottom),
        ("foreground_disparity", foreground_disparity),
        ("seed", seed),
    ):
        if not is_integer(value):
            raise TypeError(f"{name} must be an integer, got {value!r}")
    if not is_number(turn):
        raise TypeError(f"turn must be a number, got {turn!r}")
    if not np.isfinite(turn):
        raise ValueError(f"turn must be finite, got {turn}")
    if seed < 0:
        raise ValueError(f"seed must be 0 or more, got {seed}")
    if n_frames < 1:
        raise ValueError(f"n_frames must be at least 1, got {n_frames}")
    if height < 4 or width < 16:
        raise ValueError(f"frames must be at least 4 x 16 pixels, got {height} x {width}")
    top, bottom = int(top), int(bottom)
    if min(top, bottom) < 0 or foreground_disparity <= max(top, bottom):
        raise ValueError(
            "disparities must satisfy 0 <= background < foreground, got background "
            f"{background_disparity} and foreground {foreground_disparity}"
        )
    if foreground_disparity >= width // 2:
        raise ValueError(
            f"foreground_disparity={foreground_disparity} is too large for width {width}"
        )
    rng = np.random.default_rng(seed)
    rows = np.arange(height)
    back_d = np.rint(top + (bottom - top) * rows / max(height - 1, 1)).astype(np.int64)
    # The background texture is indexed by right column + max background disparity.
    offset = max(top, bottom)
    back = _texture(rng, height, width + offset)
    semi_x, semi_y = max(3.0, 0.2 * width), max(2.0, 0.3 * height)
    front = _texture(rng, 2 * int(semi_y) + 3, 2 * int(semi_x) + 3)
    scene = _Scene(back, back_d, offset, front, semi_x, semi_y, int(foreground_disparity))
    frames = []
    for t in range(n_frames):
        phase = t / max(n_frames - 1, 1)
        centre_x = (0.3 + 0.4 * phase) * width
        centre_y = (0.5 + 0.1 * np.sin(2.0 * np.pi * phase)) * height
        frames.append(scene.render(centre_x, centre_y, turn * t))
    return frames


@dataclass(frozen=True)
class _Scene:
    back: np.ndarray
    back_d: np.ndarray
    offset: int
    front: np.ndarray
    semi_x: float
    semi_y: float
    front_d: int

    def _object(self, xs, ys, cx, cy, angle):
        """Foreground membership and texture at left-view positions ``(xs, ys)``."""
        c, s = np.cos(angle), np.sin(angle)
        u = c * (xs - cx) + s * (ys - cy)
        v = -s * (xs - cx) + c * (ys - cy)
        inside = (u / self.semi_x) ** 2 + (v / self.semi_y) ** 2 <= 1.0
        fh, fw = self.front.shape
        col = np.clip(np.rint(u + fw // 2).astype(np.int64), 0, fw - 1)
        row = np.clip(np.rint(v + fh // 2).astype(np.int64), 0, fh - 1)
        return inside, self.front[row, col]

    def render(self, cx, cy, angle) -> SyntheticFrame:
        height, width = self.back.shape[0], self.back.shape[1] - self.offset
        ys, xs = np.mgrid[0:height, 0:width]
        # Left view and its disparity, straight from the scene.
        inside, front_value = self._object(xs, ys, cx, cy, angle)
        back_cols = xs - self.back_d[:, None] + self.offset
        left = np.where(inside, front_value, self.back[ys, back_cols]).astype(np.uint8)
        d_left = np.where(inside, self.front_d, self.back_d[:, None])
        # Right view by forward warping, far surfaces first (a z-buffer by disparity).
        right = np.zeros((height, width), dtype=np.uint8)
        owner = np.full((height, width), -1, dtype=np.int64)
        for d in np.unique(d_left):
            y, x = np.nonzero((d_left == d) & (xs - d >= 0))
            right[y, x - d] = left[y, x]
            owner[y, x - d] = d
        # Pixels only the right camera sees: render the surface in front there.
        hole_y, hole_x = np.nonzero(owner < 0)
        hole_in, hole_front = self._object(hole_x + self.front_d, hole_y, cx, cy, angle)
        hole_back = self.back[hole_y, hole_x + self.offset]
        right[hole_y, hole_x] = np.where(hole_in, hole_front, hole_back)
        # A left pixel is visible when it still owns its right pixel.
        target = xs - d_left
        visible = target >= 0
        visible[visible] = owner[ys[visible], target[visible]] == d_left[visible]
        truth = np.where(visible, d_left, np.nan).astype(np.float32)
        return SyntheticFrame(left, right, truth, inside)


def _texture(rng, height, width):
    """Seeded random texture, smoothed over 3 x 3 twice (survives lossy video codecs)."""
    t = rng.random((height + 4, width + 4))
    for _ in range(2):
        t = (t[:-2] + t[1:-1] + t[2:]) / 3.0
        t = (t[:, :-2] + t[:, 1:-1] + t[:, 2:]) / 3.0
    t = (t - t.min()) / max(np.ptp(t), 1e-12)
    return np.rint(20.0 + 215.0 * t).astype(np.uint8)

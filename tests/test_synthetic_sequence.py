"""The synthetic stereo sequence: seeded, consistent with its ground truth, matchable."""

import numpy as np
import pytest

from dcstereo import match
from dcstereo.evaluation.metrics import bad_pixel_rate
from dcstereo.evaluation.synthetic import synthetic_sequence


def test_same_seed_same_frames_other_seed_other_frames():
    a = synthetic_sequence(3, height=40, width=64, seed=4)
    b = synthetic_sequence(3, height=40, width=64, seed=4)
    c = synthetic_sequence(3, height=40, width=64, seed=5)
    for fa, fb, fc in zip(a, b, c, strict=True):
        np.testing.assert_array_equal(fa.left, fb.left)
        np.testing.assert_array_equal(fa.right, fb.right)
        np.testing.assert_array_equal(fa.disparity, fb.disparity)
        assert not np.array_equal(fa.left, fc.left)


def test_every_visible_left_pixel_is_its_right_partner():
    for frame in synthetic_sequence(4, height=48, width=80, seed=1):
        ys, xs = np.nonzero(np.isfinite(frame.disparity))
        d = frame.disparity[ys, xs].astype(np.int64)
        np.testing.assert_array_equal(frame.left[ys, xs], frame.right[ys, xs - d])


def test_occlusions_are_where_the_geometry_puts_them():
    frame = synthetic_sequence(3, height=48, width=80, background_disparity=(3, 3), seed=2)[-1]
    truth = frame.disparity
    # Left border: partners fall off the right image.
    assert np.isnan(truth[:, :3]).all()
    # Left of the object the background is hidden behind it in the right view: each row
    # where the object is wide enough has foreground - background = 11 occluded pixels.
    checked = 0
    for y in np.nonzero(frame.foreground.any(axis=1))[0]:
        x0, x1 = np.nonzero(frame.foreground[y])[0][[0, -1]]
        if x0 >= 3 + 12 and x1 - x0 >= 11:
            checked += 1
            assert np.isnan(truth[y, x0 - 11 : x0]).all()
            assert truth[y, x0 - 12] == 3
    assert checked > 10
    # The object itself is in front: every pixel of it is visible.
    assert (truth[frame.foreground] == 14).all()


def test_object_moves_and_turns():
    frames = synthetic_sequence(6, height=60, width=100, seed=3)
    centres = [np.nonzero(f.foreground)[1].mean() for f in frames]
    assert all(b > a for a, b in zip(centres, centres[1:], strict=False))
    # Turning: the mask is not just a translate of the first one.
    first, last = frames[0].foreground, frames[-1].foreground
    shift = int(round(centres[-1] - centres[0]))
    assert not np.array_equal(np.roll(first, shift, axis=1), last)
    # The texture turns with the object, so the object's pixels change too.
    assert not np.array_equal(frames[0].left[first][:50], frames[1].left[frames[1].foreground][:50])


def test_the_matcher_recovers_the_ground_truth():
    for frame in synthetic_sequence(3, seed=0):
        result = match(frame.left, frame.right, max_disparity=16, method="dc")
        assert bad_pixel_rate(result.disparity, frame.disparity, threshold=1.0) < 5.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_frames": 0}, "n_frames"),
        ({"n_frames": 1, "width": 8}, "at least"),
        ({"n_frames": 1, "foreground_disparity": 3}, "background < foreground"),
        ({"n_frames": 1, "width": 20}, "too large"),
    ],
)
def test_bad_arguments_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        synthetic_sequence(**kwargs)

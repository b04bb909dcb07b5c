"""The matching signal: the compiled padded signal against numpy's, bit for bit."""

import numpy as np
import pytest

from dcstereo import _signal
from dcstereo.signal import SIGNAL_STEPS, colour_channels, matching_signal, padded_signal


def _naive_padded(image, radius):
    """The reference: numpy's signal, then numpy's edge padding."""
    return np.pad(matching_signal(image), radius, mode="edge")


def _images():
    rng = np.random.default_rng(7)
    yield "uint8 gray", rng.integers(0, 256, (7, 9), dtype=np.uint8)
    yield "uint8 colour", rng.integers(0, 256, (6, 11, 3), dtype=np.uint8)
    yield "uint8 rgba", rng.integers(0, 256, (5, 4, 4), dtype=np.uint8)
    # rows of 8 pixels and more: 8 at a time (vector code), the last 8 overlapping
    for width in (8, 13, 16, 21):
        yield f"uint8 colour, {width} wide", rng.integers(0, 256, (3, width, 3), dtype=np.uint8)
    yield "uint8 rgba, 13 wide", rng.integers(0, 256, (3, 13, 4), dtype=np.uint8)
    yield "uint8 colour, reversed columns", rng.integers(0, 256, (8, 8, 3), dtype=np.uint8)[:, ::-1]
    yield "uint16 gray", rng.integers(0, 65536, (5, 6), dtype=np.uint16)
    yield "uint16 colour", rng.integers(0, 65536, (5, 6, 3), dtype=np.uint16)
    yield "uint16 big-endian", rng.integers(0, 65536, (5, 6)).astype(">u2")
    yield "float64 gray", rng.random((6, 5))
    yield "float64 rgba", rng.random((6, 5, 4))
    yield "float32 colour", rng.random((5, 7, 3)).astype(np.float32)
    yield "float16 gray", rng.random((4, 4)).astype(np.float16)
    # intensities on every half step of the 1/16 quantization: rint's ties to even
    yield "float64 ties", (np.arange(64.0) / (2 * SIGNAL_STEPS * 255.0)).reshape(2, 32)


@pytest.mark.parametrize("radius", [0, 1, 2, 3])
def test_padded_signal_equals_numpy(radius):
    for name, image in _images():
        got = padded_signal(image, radius)
        want = _naive_padded(image, radius)
        assert got.dtype == np.int32, name
        assert got.shape == want.shape, name
        np.testing.assert_array_equal(got, want, err_msg=name)


def test_colour_signal_by_hand():
    pixel = np.array([[[10, 20, 30]]], dtype=np.uint8)
    # 0.299 * 10 + 0.587 * 20 + 0.114 * 30 = 18.15 gray levels; 290.4 sixteenths
    assert matching_signal(pixel)[0, 0] == 290
    assert padded_signal(pixel, 1).tolist() == [[290] * 3] * 3


def test_same_picture_in_every_dtype_gives_one_signal():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (9, 10, 3), dtype=np.uint8)
    want = padded_signal(image, 2)
    np.testing.assert_array_equal(padded_signal(image.astype(np.uint16) * 257, 2), want)
    np.testing.assert_array_equal(padded_signal(image / 255.0, 2), want)


def test_every_uint8_colour_equals_numpy():
    # the uint8 colour path (vector code, 8 pixels at a time): every (R, G, B) triple
    codes = np.arange(2**24, dtype=np.uint32).reshape(4096, 4096)
    image = np.stack([codes >> 16, (codes >> 8) & 255, codes & 255], axis=-1).astype(np.uint8)
    np.testing.assert_array_equal(padded_signal(image, 0), matching_signal(image))


def _naive_levels(signal):
    """The reference of the gray levels: numpy's float64 division, ``rint``, ``clip``."""
    return np.clip(np.rint(signal / float(SIGNAL_STEPS)), 0, 255).astype(np.int16)


def test_signal_levels_by_hand():
    # sixteenths: 24 -> 1.5 -> 2 (tie, to even), 40 -> 2.5 -> 2, 41 -> 3, below 0 and past 255 clip
    signal = np.array([[24, 40, 41, -30, 255 * 16 + 8, 5000]], dtype=np.int32)
    levels = np.empty(signal.shape, dtype=np.int16)
    _signal.signal_levels(signal, float(SIGNAL_STEPS), levels)
    assert levels.tolist() == [[2, 2, 3, 0, 255, 255]]


def test_signal_levels_equal_numpy():
    rng = np.random.default_rng(11)
    signal = np.concatenate([np.arange(-64, 4200), rng.integers(-(2**31), 2**31, 5000)])
    signal = signal.astype(np.int32).reshape(-1, 2)
    levels = np.empty(signal.shape, dtype=np.int16)
    _signal.signal_levels(signal, float(SIGNAL_STEPS), levels)
    np.testing.assert_array_equal(levels, _naive_levels(signal))


def test_gray_colour_channels_are_the_rounded_intensity():
    for name, image in _images():
        if image.ndim == 3 and image.shape[2] >= 3:
            continue
        left, right = colour_channels(image, image[::-1])
        assert left.dtype == np.int16 and left.shape == (1, *image.shape[:2]), name
        np.testing.assert_array_equal(left[0], _naive_levels(matching_signal(image)), name)
        np.testing.assert_array_equal(right[0], _naive_levels(matching_signal(image[::-1])), name)
        # the caller's signals, where it has them, give the same channels
        signals = (padded_signal(image, 0), padded_signal(image[::-1], 0))
        given = colour_channels(image, image[::-1], signals)
        np.testing.assert_array_equal(given[0], left, name)
        np.testing.assert_array_equal(given[1], right, name)

import doctest

import numpy as np
import pytest

from dcstereo import viz

# --- paper_display ------------------------------------------------------------------


def test_paper_display_monotone_and_full_range():
    rng = np.random.default_rng(20)
    d = rng.integers(0, 40, (30, 40)).astype(np.float32)
    out = viz.paper_display(d)
    assert out.dtype == np.uint8 and out.shape == d.shape
    order = np.argsort(d, axis=None, kind="stable")
    assert (np.diff(out.ravel()[order].astype(int)) >= 0).all()
    assert out.min() == 0 and out.max() == viz.PAPER_MAX_GRAY


def test_paper_display_equalizes():
    # Many pixels at 0, few at 1 and 2: equalization spreads by pixel count, not value.
    d = np.array([[0.0] * 8 + [1.0, 2.0]])
    out = viz.paper_display(d)
    assert set(out[0, :8]) == {0}
    assert out[0, 8] == round(223 * (9 - 8) / (10 - 8)) and out[0, 9] == 223


def test_paper_display_occluded_brightest():
    rng = np.random.default_rng(21)
    d = rng.uniform(0, 64, (20, 25))
    occluded = rng.random((20, 25)) < 0.2
    out = viz.paper_display(d, occluded)
    assert (out[occluded] == 255).all()
    assert out[~occluded].max() < out[occluded].min()
    # NaN pixels count as occluded when no mask is given...
    out_nan = viz.paper_display(np.where(occluded, np.nan, d))
    np.testing.assert_array_equal(out_nan, out)
    # ...and are white also when the mask misses them.
    d_nan = d.copy()
    d_nan[0, 0] = np.nan
    assert viz.paper_display(d_nan, np.zeros_like(occluded))[0, 0] == 255


def test_paper_display_ignores_values_under_occlusion():
    d = np.array([[1.0, 2.0, 1000.0]])
    out = viz.paper_display(d, np.array([[False, False, True]]))
    np.testing.assert_array_equal(out, [[0, 223, 255]])


def test_paper_display_half_pixels():
    d = np.array([[3.0, 3.5, 4.0, 4.5, np.nan]], dtype=np.float32)
    out = viz.paper_display(d)
    np.testing.assert_array_equal(out, [[0, 74, 149, 223, 255]])


def test_paper_display_constant_map():
    out = viz.paper_display(np.full((4, 5), 7.5))
    np.testing.assert_array_equal(out, np.full((4, 5), 112))


def test_paper_display_all_nan():
    out = viz.paper_display(np.full((3, 3), np.nan))
    np.testing.assert_array_equal(out, np.full((3, 3), 255))


def test_paper_display_validates():
    with pytest.raises(ValueError, match="2-D"):
        viz.paper_display(np.zeros(5))
    with pytest.raises(ValueError, match="occluded has shape"):
        viz.paper_display(np.zeros((2, 2)), np.zeros((2, 3), dtype=bool))
    with pytest.raises(TypeError, match="occluded must be a bool array"):
        viz.paper_display(np.zeros((2, 2)), np.zeros((2, 2)))


# --- colorize -----------------------------------------------------------------------


def test_colorize_shape_dtype_and_ends():
    import matplotlib

    d = np.array([[0.0, 5.0, 10.0]])
    out = viz.colorize(d, cmap="viridis")
    assert out.shape == (1, 3, 3) and out.dtype == np.uint8
    lut = matplotlib.colormaps["viridis"]
    np.testing.assert_array_equal(out[0, 0], lut(0.0, bytes=True)[:3])
    np.testing.assert_array_equal(out[0, 2], lut(1.0, bytes=True)[:3])


def test_colorize_invalid_colour():
    d = np.array([[1.0, np.nan], [np.inf, 2.0]])
    out = viz.colorize(d, invalid=(255, 0, 255))
    np.testing.assert_array_equal(out[0, 1], [255, 0, 255])
    np.testing.assert_array_equal(out[1, 0], [255, 0, 255])
    assert not (out[0, 0] == [255, 0, 255]).all()


def test_colorize_constant_and_all_nan():
    out = viz.colorize(np.full((2, 2), 3.0))
    assert (out == out[0, 0]).all()
    np.testing.assert_array_equal(viz.colorize(np.full((2, 2), np.nan)), np.zeros((2, 2, 3)))


def test_colorize_limits_clip():
    d = np.array([[-5.0, 0.0, 10.0, 50.0]])
    out = viz.colorize(d, vmin=0, vmax=10)
    np.testing.assert_array_equal(out[0, 0], out[0, 1])
    np.testing.assert_array_equal(out[0, 2], out[0, 3])
    with pytest.raises(ValueError, match="vmin"):
        viz.colorize(d, vmin=3, vmax=1)


def test_colorize_unknown_cmap():
    with pytest.raises(ValueError, match="unknown matplotlib colour map 'no_such_map'"):
        viz.colorize(np.zeros((2, 2)), cmap="no_such_map")


def test_colorize_bad_invalid_colour():
    with pytest.raises(ValueError, match="invalid must be three integers"):
        viz.colorize(np.zeros((2, 2)), invalid=(0, 0, 300))


# --- error_map ----------------------------------------------------------------------


def test_error_map_hand_made():
    d = np.array([[1.0, 5.0, np.nan], [2.0, 3.0, 4.0]])
    gt = np.array([[1.5, 3.0, 2.0], [np.nan, 3.0, 4.0]])
    mask = np.array([[True, True, True], [True, True, False]])
    out = viz.error_map(d, gt, threshold=1.0, mask=mask)
    expected = np.array(
        [
            [viz.ERROR_GOOD, viz.ERROR_BAD, viz.ERROR_MISSING],
            [viz.ERROR_UNSCORED, viz.ERROR_GOOD, viz.ERROR_UNSCORED],
        ],
        dtype=np.uint8,
    )
    np.testing.assert_array_equal(out, expected)
    np.testing.assert_array_equal(out[0, 0], [200, 200, 200])
    np.testing.assert_array_equal(out[0, 1], [255, 0, 0])
    np.testing.assert_array_equal(out[0, 2], [0, 0, 255])


def test_error_map_threshold_is_inclusive():
    out = viz.error_map(np.array([[2.0, 2.0]]), np.array([[1.0, 0.5]]), threshold=1.0)
    np.testing.assert_array_equal(out[0], [viz.ERROR_GOOD, viz.ERROR_BAD])


def test_error_map_validates():
    with pytest.raises(ValueError, match="truth has shape"):
        viz.error_map(np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="threshold must be 0 or more"):
        viz.error_map(np.zeros((2, 2)), np.zeros((2, 2)), threshold=-1)


# --- draw_points --------------------------------------------------------------------


def test_draw_points_square_and_copy():
    image = np.zeros((7, 7, 3), dtype=np.uint8)
    out = viz.draw_points(image, [3], [2], color=(0, 255, 0), radius=1)
    assert not image.any()
    painted = (out == [0, 255, 0]).all(axis=-1)
    expected = np.zeros((7, 7), dtype=bool)
    expected[1:4, 2:5] = True
    np.testing.assert_array_equal(painted, expected)


def test_draw_points_clips_at_edges():
    image = np.zeros((4, 5), dtype=np.uint8)
    out = viz.draw_points(image, [0, 4.4, 100], [0, 3, -50], radius=1)
    assert out.shape == (4, 5, 3)
    painted = (out == [255, 0, 0]).all(axis=-1)
    expected = np.zeros((4, 5), dtype=bool)
    expected[0:2, 0:2] = True
    expected[2:4, 3:5] = True
    np.testing.assert_array_equal(painted, expected)


def test_draw_points_radius_zero_and_no_points():
    rng = np.random.default_rng(22)
    image = rng.integers(0, 256, (3, 3, 3), dtype=np.uint8)
    out = viz.draw_points(image, [1], [1], color=(1, 2, 3), radius=0)
    np.testing.assert_array_equal(out[1, 1], [1, 2, 3])
    assert (np.delete(out.reshape(9, 3), 4, axis=0) == np.delete(image.reshape(9, 3), 4, 0)).all()
    np.testing.assert_array_equal(viz.draw_points(image, [], []), image)


def test_draw_points_validates():
    image = np.zeros((3, 3, 3), dtype=np.uint8)
    with pytest.raises(ValueError, match="differ in length"):
        viz.draw_points(image, [1, 2], [1])
    with pytest.raises(ValueError, match="finite"):
        viz.draw_points(image, [np.nan], [1])
    with pytest.raises(ValueError, match="radius"):
        viz.draw_points(image, [1], [1], radius=-1)
    with pytest.raises(TypeError, match="uint8"):
        viz.draw_points(image.astype(float), [1], [1])


# --- preview ------------------------------------------------------------------------


def test_preview_dispatch():
    rng = np.random.default_rng(23)
    d = rng.uniform(0, 10, (5, 6))
    occluded = rng.random((5, 6)) < 0.3
    np.testing.assert_array_equal(viz.preview(d, occluded), viz.paper_display(d, occluded))
    colour = viz.preview(d, occluded, style="color")
    assert colour.shape == (5, 6, 3)
    np.testing.assert_array_equal(colour, viz.colorize(np.where(occluded, np.nan, d)))


def test_preview_unknown_style():
    with pytest.raises(ValueError, match="unknown preview style 'fancy'"):
        viz.preview(np.zeros((2, 2)), style="fancy")


def test_docstring_examples():
    failures, _ = doctest.testmod(viz, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert failures == 0


def test_colorize_names_the_limit_the_caller_gave():
    d = np.array([[1.0, 5.0]], dtype=np.float32)
    with pytest.raises(
        ValueError, match=r"^vmin \(10\) must not be larger than the largest value \(5\)$"
    ):
        viz.colorize(d, vmin=10)
    with pytest.raises(
        ValueError, match=r"^the least value \(1\) must not be larger than vmax \(0\)$"
    ):
        viz.colorize(d, vmax=0)
    with pytest.raises(ValueError, match=r"^vmin \(3\) must not be larger than vmax \(2\)$"):
        viz.colorize(d, vmin=3, vmax=2)

"""Properties that hold for any input: sizes, ranges and the ordering constraint."""

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import dcstereo


@st.composite
def problems(draw):
    height = draw(st.integers(1, 9))
    width = draw(st.integers(2, 40))
    window = draw(st.sampled_from([w for w in (1, 3, 5) if w <= min(height, width)]))
    dmin = draw(st.integers(-(width - 1), width - 1))
    dmax = draw(st.integers(dmin, width - 1))
    seed = draw(st.integers(0, 2**32 - 1))
    method = draw(st.sampled_from(dcstereo.METHODS))
    return height, width, window, dmin, dmax, seed, method


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems())
# found by this test: the planes carried a left-border pixel's value past the right image
@example((3, 24, 3, -3, 2, 293, "sgm-accurate"))
def test_any_size_and_range_gives_a_consistent_result(problem):
    height, width, window, dmin, dmax, seed, method = problem
    rng = np.random.default_rng(seed)
    left = rng.integers(0, 256, (height, width), dtype=np.uint8)
    right = rng.integers(0, 256, (height, width), dtype=np.uint8)
    result = dcstereo.match(
        left, right, max_disparity=dmax, min_disparity=dmin, method=method, window=window
    )
    assert result.disparity.shape == (height, width) and result.disparity.dtype == np.float32
    own = result.unfilled()  # sgm fills its map: the estimates it made itself
    d = own.disparity
    finite = np.isfinite(d)
    # estimates lie in the searched range and point inside the right image: its pixels'
    # centres are 0 .. width - 1, a sub-pixel fit reaches half a pixel either side of them
    assert ((d[finite] >= dmin) & (d[finite] <= dmax)).all()
    cols = np.broadcast_to(np.arange(width), d.shape)
    assert ((cols[finite] - d[finite] >= -0.5) & (cols[finite] - d[finite] <= width - 0.5)).all()
    # every pixel without an estimate says why
    reasons = dcstereo.FLAG_OCCLUDED | dcstereo.FLAG_BORDER | dcstereo.FLAG_MISMATCH
    assert (own.flags[~finite] & reasons).all()
    if method not in ("block", *dcstereo.params.SGM_METHODS):
        # the DP methods obey the ordering constraint: along a row, matched right pixels
        # strictly increase with the left pixel
        pairs = result.pairs()
        for row in range(height):
            xr = pairs[pairs[:, 0] == row, 2]
            assert (np.diff(xr) > 0).all()
    filled = result.filled()
    if finite.any(axis=1).all():
        assert np.isfinite(filled.disparity).all()

"""Row-band tiling of :func:`dcstereo.match` for images too large to match at once.

The scanline methods (all but ``sgm``) match each scanline on its own, and the window cost
of row ``y`` reads only rows ``y - r .. y + r`` (``r = window // 2``; rows beyond the image
edge are the replicated edge row). A band of output rows ``y0 .. y1 - 1`` therefore needs
the input rows ``y0 - r .. y1 - 1 + r`` (clipped to the image) and nothing else, and
matching that band on its own gives bit for bit the rows of the whole-image result: the
band's own edge padding only touches its first and last ``r`` rows, which are context, not
output. The bands can
run one after the other (memory: one band) or as one Dask task each. The one step that
reads across rows of the map, the ``median`` post-filter, runs once on the stitched map
(then ``fill``).

``sgm`` aggregates its costs along paths that cross the rows, so no band is exact on its
own: its bands read :data:`dcstereo.methods.sgm.STRIP_MARGIN` more rows of context on each side
(as its own strips do, :mod:`dcstereo.methods.sgm`), and the result equals the whole-image one
where a band's context reaches the image's edges, and differs slightly near the seams
otherwise. Its fill (which searches across rows) and then its median run once on the
stitched map. Its ``row_alignment`` measures the rows' offsets once, on the whole pair
(:func:`dcstereo.methods.sgm.sgm_row_field`), and the bands match the right view so moved.
Its ``edges`` stage runs after the median, on the stitched map, over the whole views
(:func:`dcstereo.methods.sgm.sgm_views`, the right view moved as the bands' was; with
``photometric``, its colours mapped over the whole pair, where each band maps its own).
"""

from dataclasses import dataclass, replace

import numpy as np

from dcstereo._checks import is_integer
from dcstereo.api import match
from dcstereo.costs.row_offsets import moved_view
from dcstereo.methods._pipeline import median_post_filter
from dcstereo.methods.sgm import STRIP_MARGIN, sgm_row_field, sgm_views
from dcstereo.params import SGM_METHODS, MatchParams, spelled_out
from dcstereo.refine.consistency import fill_inconsistent
from dcstereo.refine.edges import refine_edges
from dcstereo.result import DisparityResult
from dcstereo.signal import check_pair


@dataclass(frozen=True)
class Band:
    """One row band: the rows it outputs and the rows it reads.

    Attributes
    ----------
    start, stop : int
        Output rows ``start .. stop - 1`` of the whole image.
    read_start, read_stop : int
        Input rows ``read_start .. read_stop - 1`` the band is matched on (the output rows
        plus the window's context, clipped to the image).
    """

    start: int
    stop: int
    read_start: int
    read_stop: int


def row_bands(height: int, tile_rows: int, window: int, context: int | None = None) -> list[Band]:
    """Split ``height`` rows into bands of ``tile_rows`` output rows with window context.

    Each band reads ``context`` (default ``window // 2``) extra rows on each side (fewer at
    the image edges), and at least ``window`` rows in all when the image has them, since a
    band thinner than the window is refused by :func:`dcstereo.match`.

    Parameters
    ----------
    height : int
        Image height in rows.
    tile_rows : int
        Output rows per band (the last band may be shorter).
    window : int
        Odd side of the matching window.
    context : int, optional
        Rows of context on each side; default ``window // 2``.

    Returns
    -------
    list of Band
        Covering ``0 .. height - 1`` in order, without overlap of output rows.

    Examples
    --------
    >>> [(b.start, b.stop, b.read_start, b.read_stop) for b in row_bands(10, 4, 3)]
    [(0, 4, 0, 5), (4, 8, 3, 9), (8, 10, 7, 10)]
    """
    for name, value in (("height", height), ("tile_rows", tile_rows), ("window", window)):
        if not is_integer(value):
            raise TypeError(f"{name} must be an integer, got {value!r}")
    height, tile_rows, window = int(height), int(tile_rows), int(window)
    if height < 0:
        raise ValueError(f"height must be 0 or positive, got {height}")
    if tile_rows < 1:
        raise ValueError(f"tile_rows must be at least 1, got {tile_rows}")
    if window < 1 or window % 2 == 0:
        raise ValueError(f"window must be a positive odd integer, got {window}")
    radius = window // 2 if context is None else int(context)
    bands = []
    for start in range(0, height, tile_rows):
        stop = min(start + tile_rows, height)
        read_start, read_stop = max(0, start - radius), min(height, stop + radius)
        short = window - (read_stop - read_start)
        if short > 0:  # extra context rows change nothing; the band just has to be legal
            read_stop = min(height, read_stop + short)
            read_start = max(0, read_stop - window)
        bands.append(Band(start, stop, read_start, read_stop))
    return bands


def match_tiled(
    left: np.ndarray,
    right: np.ndarray,
    *,
    tile_rows: int,
    client=None,
    **match_kwargs,
) -> DisparityResult:
    """Run :func:`dcstereo.match` band by band and stitch an identical result.

    Parameters
    ----------
    left, right : ndarray, shape (H, W) or (H, W, 3|4)
        The rectified pair, as for :func:`dcstereo.match`.
    tile_rows : int
        Output rows per band; each band also reads ``window // 2`` rows of context on
        each side (``sgm``: :data:`~dcstereo.methods.sgm.STRIP_MARGIN` more).
    client : distributed.Client, optional
        Run one task per band on this Dask client (numba uses one thread inside each
        task, so the workers' cores are not oversubscribed). None: run the bands here,
        one after the other, each with all of numba's threads.
    **match_kwargs
        ``max_disparity`` (required), ``min_disparity``, ``method`` and the options of
        :func:`dcstereo.match`.

    Returns
    -------
    DisparityResult
        Equal to ``match(left, right, **match_kwargs)`` in every field: ``disparity``,
        ``flags`` and ``path_cost`` row by row, ``features`` with their rows in
        whole-image coordinates (``sgm``: where the bands' context covers the image; see
        the module's text).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (30, 40), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)
    >>> tiled = match_tiled(left, right, tile_rows=8, max_disparity=6)
    >>> whole = match(left, right, max_disparity=6)
    >>> bool(np.array_equal(tiled.disparity, whole.disparity, equal_nan=True))
    True
    """
    if "max_disparity" not in match_kwargs:
        raise TypeError("match_tiled() needs the keyword argument max_disparity")
    params = MatchParams(**match_kwargs)  # validate once, before any band runs
    match_kwargs = spelled_out(match_kwargs)  # sgm-accurate: sgm with its stages named
    left, right = check_pair(left, right)
    height, width = left.shape[:2]
    params.check_image_size(height, width)
    across = params.method in SGM_METHODS  # paths, fill and median read across the bands
    context = params.window // 2 + (STRIP_MARGIN if across else 0)
    bands = row_bands(height, tile_rows, params.window, context)
    if params.median or across:  # read rows of the neighbouring bands: once, on the whole
        match_kwargs = {**match_kwargs, "median": 0, "fill": False}
    if params.edges is not None:  # after the median: once, on the stitched map
        match_kwargs = {**match_kwargs, "edges": None}
    if across and params.row_alignment == "estimated":  # one field for the whole pair
        field = sgm_row_field(left, right, params)
        offsets = None if field is None else field.to_move()
        if offsets is not None:
            right = moved_view(right, offsets)
        match_kwargs = {**match_kwargs, "row_alignment": None}
    if client is None:
        parts = [
            match(
                left[b.read_start : b.read_stop], right[b.read_start : b.read_stop], **match_kwargs
            )
            for b in bands
        ]
    else:
        futures = []
        for b in bands:
            pieces = client.scatter(
                [left[b.read_start : b.read_stop], right[b.read_start : b.read_stop]]
            )
            futures.append(client.submit(_match_band, *pieces, match_kwargs, pure=False, retries=2))
        parts = client.gather(futures)
    result = replace(_stitch(bands, parts, height, width), params=params)
    if across:
        if params.fill:
            result = fill_inconsistent(result, left)
        if params.median:
            result = median_post_filter(result, left, params.median)
        if params.edges is not None:  # the right view moved as the bands' was
            views = sgm_views(left, right, replace(params, method="sgm", row_alignment=None))
            result = refine_edges(result, *views)
    elif params.median:
        result = median_post_filter(result, left, params.median)
        if params.fill:
            result = result.filled()
    return result


def _match_band(left: np.ndarray, right: np.ndarray, match_kwargs: dict) -> DisparityResult:
    """Dask task: match one band with one numba thread (the worker's cores are its tasks')."""
    import numba

    numba.set_num_threads(1)
    return match(left, right, **match_kwargs)


def _stitch(bands: list[Band], parts: list[DisparityResult], height: int, width: int):
    first = parts[0]
    disparity = np.empty((height, width), dtype=first.disparity.dtype)
    flags = np.empty((height, width), dtype=first.flags.dtype)
    path_cost = np.empty(height, dtype=first.path_cost.dtype)
    features = [] if first.features is not None else None
    for band, part in zip(bands, parts, strict=True):
        lo, hi = band.start - band.read_start, band.stop - band.read_start
        disparity[band.start : band.stop] = part.disparity[lo:hi]
        flags[band.start : band.stop] = part.flags[lo:hi]
        path_cost[band.start : band.stop] = part.path_cost[lo:hi]
        if features is not None:
            rows = part.features[:, 0]
            kept = part.features[(rows >= lo) & (rows < hi)].copy()
            kept[:, 0] += band.read_start
            features.append(kept)
    if features is not None:
        features = np.concatenate(features, axis=0)
    return DisparityResult(disparity, flags, first.params, path_cost, features)

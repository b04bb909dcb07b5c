"""Iterative region voting over cross-based support regions (ADCensus, Mei et al. 2011).

A pixel without a trusted estimate takes the disparity that most trusted estimates of its
support region (pixels of a similar colour connected to it by crosses,
:func:`cross_arms`) agree on, repeated ``passes`` times so that the votes reach further.
"""

import numpy as np

from .kernels import voting as _kernels


def cross_arms(colour: np.ndarray, tau1: int = 20, tau2: int = 6, l1: int = 34,
               l2: int = 17) -> np.ndarray:  # fmt: skip
    """Arms (left, right, up, down) of each pixel: ``(4, H, W)`` int32 (see the kernel)."""
    colour = np.ascontiguousarray(colour)
    arms = np.empty((4,) + colour.shape[1:], dtype=np.int32)
    _kernels.cross_arms(colour, int(tau1), int(tau2), int(l1), int(l2), arms)
    return arms


def region_vote(
    disparity: np.ndarray,
    colour: np.ndarray,
    *,
    trusted: np.ndarray,
    todo: np.ndarray,
    low: int,
    high: int,
    passes: int = 5,
    min_votes: int = 20,
    min_share: float = 0.4,
    arms: np.ndarray | None = None,
    **arm_options,
) -> tuple[np.ndarray, np.ndarray]:
    """Refine the ``todo`` pixels of ``disparity`` by votes; return the map and who voted.

    After each pass the pixels that took a vote become trusted voters and leave ``todo``.
    """
    if arms is None:
        arms = cross_arms(colour, **arm_options)
    d = np.ascontiguousarray(disparity, dtype=np.float32)
    trusted = trusted & np.isfinite(d)
    todo = todo.copy()
    voted = np.zeros(d.shape, dtype=bool)
    out = np.empty_like(d)
    done = np.empty(d.shape, dtype=bool)
    for _ in range(passes):
        _kernels.vote_rows(d, trusted, todo, arms, int(low), int(high - low + 1), int(min_votes),
                           float(min_share), out, done)  # fmt: skip
        if not done.any():
            break
        d, out = out, d
        trusted = trusted | done
        todo = todo & ~done
        voted |= done
    return d, voted

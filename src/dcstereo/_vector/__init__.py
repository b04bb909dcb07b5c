"""The hand-written LLVM vector code, each operation beside its plain form, and the kernel cache.

* :mod:`.simd`: the lane helpers every vector kernel uses (the band width ``BAND_ROWS``,
  the cycle counter, pixel packing);
* :mod:`.costs`: the moved-window costs of the band kernels (:mod:`dcstereo.costs.band`);
* :mod:`.dp`: the cell steps of the band DPs (:mod:`dcstereo.scanline.band_dp`);
* :mod:`.sgm`: the int16 path steps of semi-global aggregation (:mod:`dcstereo.aggregate.sgm`);
* :mod:`.scratch`: where scratch buffers are placed;
* :mod:`._cache`: numba's on-disk cache keyed by the hash of every source of the package.
"""

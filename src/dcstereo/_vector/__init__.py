"""The hand-written LLVM vector code, each operation beside its plain form, and the kernel cache.

* ``simd``: the lane helpers every vector kernel uses (the band width ``BAND_ROWS``,
  the cycle counter, pixel packing);
* ``costs``: the moved-window costs of the band kernels (:mod:`dcstereo.costs.band`);
* ``dp``: the cell steps of the band DPs (:mod:`dcstereo.scanline.band_dp`);
* ``sgm``: the int16 path steps of semi-global aggregation (:mod:`dcstereo.aggregate.sgm`);
* ``scratch``: where scratch buffers are placed;
* ``_cache``: numba's on-disk cache keyed by the hash of every source of the package.
"""

import os

#: Whether compiled code runs the hand-written vector forms (the default) or numba's
#: compilation of their plain forms: set ``DCSTEREO_VECTOR=0`` in the environment before
#: importing dcstereo for the plain forms (to compare, or where the vector code is suspect).
#: The kernel cache keeps the two apart. Every operation has a plain form but the DP's cell
#: chains of the band methods (``dp._cells5_chain``, ``dp._cells3_chain``), whose plain
#: forms take optional arrays numba cannot compile: they stay vector code either way.
VECTOR = os.environ.get("DCSTEREO_VECTOR", "1").strip() != "0"

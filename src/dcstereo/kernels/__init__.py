"""The numba kernels of dcstereo, one module per stage of the data path.

Where the paper's parts live (``../shared/paper/NOTES.md``):

* eq. 4, the window costs of a scanline's DSI: :mod:`.costs` (one row; SAD and
  Birchfield-Tomasi), :mod:`.band_costs` (``BAND_ROWS`` rows in lockstep);
* eq. 5 and section 3, the scanline DP: :mod:`.dp` (one row, free or anchored ends),
  :mod:`.band_dp` (a band of rows, free or through pins); ``dsi3``, ``dsi5`` and ``block``
  row by row: :mod:`.rows`;
* section 2, divide and conquer: :mod:`.divide` (the search on a scanline, its fill; the
  home of section 2), :mod:`.features` (its measures: window variance, SER and VS of eq. 2
  and 3, the uniqueness ratio, the block match), :mod:`.divide_bands` and
  :mod:`.band_match` (the same search on a band's costs);
* Intille and Bobick's ground control points (``dsi3-gcp``): :mod:`.gcp`;
* the method of Redert et al. [6] (``redert``): :mod:`.redert`;
* the drivers of the band methods: :mod:`.bands`; what the kernels take: :mod:`.records`;
* before and after the match: :mod:`.signal` (the matching signal), :mod:`.subpixel`,
  :mod:`.postfilter` (the median), :mod:`.confidence`;
* the hand-written LLVM vector code, each operation beside its plain form:
  :mod:`.simd`, :mod:`.simd_costs`, :mod:`.simd_dp`; scratch placement: :mod:`.scratch`;
* beyond the paper, the ``sgm`` pipeline (the default method): :mod:`.census` (census and
  colour costs, the cost volume), :mod:`.sgm` (the path passes, the choice, the left-right
  check), :mod:`.sgm_simd` (its vector operations), :mod:`.consistency` (the fill of the
  pixels the check rejected), :mod:`.median` (the sorting-network median of full windows).

Importing this package first installs :mod:`._cache`'s locator, so that every kernel
compiled with ``cache=True`` in these modules is stored under a stamp made from the hash of
*all* of them: numba's own stamp is the hash of the one file a function is written in, and
would keep a kernel compiled against an old version of a function it calls from another
module. Each module imports this package (through its relative imports), so the locator is
in place before the first ``@njit(cache=True)`` runs.
"""

from ._cache import install_locator

install_locator()

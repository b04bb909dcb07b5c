"""The numba kernels of dcstereo, one module per stage of the data path.

Importing this package first installs :mod:`._cache`'s locator, so that every kernel
compiled with ``cache=True`` in these modules is stored under a stamp made from the hash of
*all* of them: numba's own stamp is the hash of the one file a function is written in, and
would keep a kernel compiled against an old version of a function it calls from another
module. Each module imports this package (through its relative imports), so the locator is
in place before the first ``@njit(cache=True)`` runs.
"""

from ._cache import install_locator

install_locator()

"""Type predicates of the argument checks: one meaning of "an integer" and "a number".

NumPy's scalar types count (``np.int64(5)``, ``np.float32(0.5)``: NumPy registers them
with :mod:`numbers`), booleans do not (``True`` is an ``int`` to Python, a typo to us).
"""

import numbers


def is_integer(value) -> bool:
    """Whether ``value`` is an integer: a Python or NumPy integer, not a boolean."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def is_number(value) -> bool:
    """Whether ``value`` is a real number: a Python or NumPy integer or float, not a boolean."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)

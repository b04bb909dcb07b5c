"""The matching cases the whole-library tests run: every method, and every method with an
option that takes it to another kernel path."""

import dcstereo


def takes(method, max_disparity, **options):
    """Whether ``method`` accepts ``options`` (MatchParams raises ValueError otherwise)."""
    try:
        dcstereo.MatchParams(max_disparity=max_disparity, method=method, **options)
    except ValueError:
        return False
    return True


def method_cases(max_disparity, **variants):
    """``(id, keyword arguments of match)``: each method, then each method with each variant.

    ``variants`` maps a suffix of the id to options, as ``bt={"cost": "bt"}``; a method
    that does not take a variant's options is left out of it.
    """
    cases = [(method, {"method": method}) for method in dcstereo.METHODS]
    for suffix, options in variants.items():
        cases += [
            (f"{method}+{suffix}", {"method": method, **options})
            for method in dcstereo.METHODS
            if takes(method, max_disparity, **options)
        ]
    return cases

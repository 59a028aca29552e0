"""Equality of evaluate() records where NaN (an unresolved metric) equals NaN."""

import math


def same_record(a: dict, b: dict) -> bool:
    """True when both records have the same keys and values, NaN matching NaN."""

    def same(x, y):
        if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
            return True
        return x == y

    return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)

"""Statistics shared by the analysis tools of `results/tools/` (standard library only)."""

import math


def mean_se(values):
    """The mean and its standard error (sample standard deviation / √n); SE is NaN for n < 2,
    both are NaN for no values."""
    n = len(values)
    if n == 0:
        return float("nan"), float("nan")
    m = sum(values) / n
    if n < 2:
        return m, float("nan")
    return m, math.sqrt(sum((x - m) ** 2 for x in values) / (n - 1) / n)

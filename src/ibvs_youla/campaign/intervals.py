"""Confidence intervals of rates: the Wilson score interval of k successes in n runs."""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from ..exceptions import InvalidParameterError

__all__ = ["wilson_interval"]


def wilson_interval(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a rate ``k / n`` (Wilson 1927; Brown, Cai & DasGupta 2001, Eq. (4)).

    ``(p + z^2 / 2n -+ z sqrt(p (1 - p) / n + z^2 / 4n^2)) / (1 + z^2 / n)`` with ``p = k / n``
    and ``z`` the ``(1 + confidence) / 2`` quantile of the standard normal (1.95996 at 95 %);
    exactly 0 for ``k = 0`` and 1 for ``k = n``. ``n = 0`` gives ``(0, 1)``: every rate is possible.

    Raises:
        InvalidParameterError: ``k`` or ``n`` not integers with ``0 <= k <= n``, or a confidence
            outside (0, 1).
    """
    if not 0.0 < confidence < 1.0:
        raise InvalidParameterError("confidence", confidence, "a number in (0, 1)")
    if any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in (k, n)) or not 0 <= k <= n:
        raise InvalidParameterError("(k, n)", (k, n), "integers with 0 <= k <= n")
    if n == 0:
        return 0.0, 1.0
    z = NormalDist().inv_cdf(0.5 + 0.5 * confidence)
    p, z2 = k / n, z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    low = 0.0 if k == 0 else max(0.0, centre - half)  # exact ends: the formula gives 0 and 1 there
    high = 1.0 if k == n else min(1.0, centre + half)
    return low, high

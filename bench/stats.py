"""Shared figures for the benchmarks."""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence

from cyborg.daemon.vision.interest import InterestPoint


def latency(samples: list[float]) -> dict[str, float]:
    """Median and p99 of durations in seconds, as milliseconds.

    >>> latency([0.001, 0.002, 0.003])
    {'median_ms': 2.0, 'p99_ms': 3.0}
    """
    samples = sorted(samples)
    return {
        "median_ms": 1e3 * statistics.median(samples),
        "p99_ms": 1e3 * samples[min(len(samples) - 1, round(0.99 * (len(samples) - 1)))],
    }


def wilson(rate: float, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95 % Wilson score interval of a success rate measured on ``n`` trials.

    A rate from 120 scenes is a sample: 86.7 % could be 79-92 % on other scenes of the same
    kind, and a change of one scene is 0.8 points. The Wilson interval stays inside 0..1 and
    is sound near 0 and 1, where goals and baselines often sit (the normal approximation is
    not). Hand-written: five lines, where scipy or statsmodels would be a new dependency.

    >>> [round(100 * x, 1) for x in wilson(104 / 120, 120)]
    [79.4, 91.6]
    >>> wilson(1.0, 120)[1], wilson(0.5, 0)
    (1.0, (0.0, 1.0))
    """
    if n <= 0:
        return 0.0, 1.0
    z2n = z * z / n
    centre = (rate + z2n / 2.0) / (1.0 + z2n)
    half = z * math.sqrt(rate * (1.0 - rate) / n + z2n / (4.0 * n)) / (1.0 + z2n)
    return max(0.0, centre - half), min(1.0, centre + half)


def repeats(
    first: Sequence[InterestPoint], second: Sequence[InterestPoint], tolerance: float
) -> bool:
    """Both looks have a best point and they lie within ``tolerance`` of each other: will a
    second look at the same ground send the rover to the same place? (repeat@1)

    >>> P = InterestPoint
    >>> repeats([P(1, 10.0, 10.0, 1.0)], [P(1, 13.0, 14.0, 1.0)], 5.0), repeats([], [], 5.0)
    (True, False)
    """
    if not first or not second:
        return False
    return math.hypot(first[0].x - second[0].x, first[0].y - second[0].y) <= tolerance

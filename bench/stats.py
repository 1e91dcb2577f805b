"""Shared figures for the benchmarks."""

from __future__ import annotations

import statistics


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

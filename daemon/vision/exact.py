"""The science's OpenCV calls on OpenCV's own code, not Intel IPP's: the same image gives the
same result, bit for bit, on every run.

OpenCV hands some calls to IPP when it is built in (the PyPI wheels have it), and IPP's
floating-point paths depend on where the arrays happen to lie in memory: ``cv2.magnitude``
of the same two arrays gives 1-ulp different results for 2 of 4 alignments of its output
(the interest map's roundness gave a different map on one run in two of an image with a
no-data fill). IPP is switched per thread, so it is switched off where the science runs
and back as it was afterwards: callers keep their OpenCV as they set it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

import cv2

__all__ = ["exact"]

P = ParamSpec("P")
R = TypeVar("R")


def exact(fn: Callable[P, R]) -> Callable[P, R]:
    """``fn`` run with IPP off in the calling thread (and left as it was after)."""

    @functools.wraps(fn)
    def run(*args: P.args, **kwargs: P.kwargs) -> R:
        was = cv2.ipp.useIPP()
        cv2.ipp.setUseIPP(False)
        try:
            return fn(*args, **kwargs)
        finally:
            cv2.ipp.setUseIPP(was)

    return run

"""Compiled per-pixel kernels (numba), where a chain of whole-image passes was the cost.

A chain of OpenCV/numpy calls reads and writes every pixel once per call: the shadow gate's
comparison of each pixel with its lit rock took some forty such passes over three-channel
float images; one compiled loop does it in one, with the same arithmetic. A module marks
such a loop with :func:`kernel`.

Compiled code is cached on disk under the service's cache directory (:func:`cache_dir`), so
only the first start after an install compiles; :func:`warm` loads every kernel, and the
vision worker calls it when it starts, so the first station is not the slow one.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np

__all__ = ["cache_dir", "kernel", "warm"]

F = TypeVar("F", bound=Callable)


def cache_dir() -> Path:
    """Where compiled kernels are kept: systemd's ``CacheDirectory=`` of the unit
    (``$CACHE_DIRECTORY``), else the user's cache (``$XDG_CACHE_HOME`` or ``~/.cache``), in
    ``cyborgd/numba``; the first that can be written, else a temporary folder (the hardened
    unit makes the home and the installation read-only, and numba refuses to load a cached
    function where it cannot write)."""
    places = [Path(p) for p in os.environ.get("CACHE_DIRECTORY", "").split(":") if p]
    xdg = os.environ.get("XDG_CACHE_HOME")
    places.append((Path(xdg) if xdg else Path.home() / ".cache") / "cyborgd")
    places.append(Path(tempfile.gettempdir()) / f"cyborgd-{os.getuid()}")
    for place in places:
        try:
            (place / "numba").mkdir(parents=True, exist_ok=True)
            tempfile.TemporaryFile(dir=place / "numba").close()
        except OSError:
            continue
        return place / "numba"
    raise OSError(f"no writable cache folder among {', '.join(map(str, places))}")


# numba reads its cache folder when it is first imported: set before the import.
os.environ.setdefault("NUMBA_CACHE_DIR", str(cache_dir()))

import numba  # noqa: E402 - after its cache folder is set


def kernel(fn: F) -> F:
    """``fn`` compiled by numba (no Python objects; cached on disk). Python floats are
    float64 in it: arithmetic on float32 array values with them is float64."""
    return numba.njit(cache=True, nogil=True)(fn)


def warm() -> None:
    """Load every kernel (compiling it the first time): the whole science core, each profile,
    on a small noisy image."""
    from .job import analyze_image  # noqa: PLC0415 - it imports the kernels' modules
    from .params import PROFILES  # noqa: PLC0415

    rng = np.random.default_rng(0)
    image = rng.integers(40, 200, (96, 128, 3), dtype=np.uint8)
    for params in dict.fromkeys(PROFILES.values()):  # each distinct profile once
        analyze_image(image, params)

"""The errors of a real head that the emulator can play: pointing error and backlash.

An open-loop stepper unit counts steps, not angles: it reports the position it was told to
go to while the camera on it looks a little elsewhere. :class:`HeadErrors` adds the two
effects that dominate on a real PTU-46 and its mount:

- **pointing error**: a repeatable error that varies smoothly with where the head points
  (gear eccentricity, shaft and mount misalignment, cable drag), of rms ``pointing`` degrees
  on each axis. Places tens of degrees apart are off independently, so every move to a new
  place lands a few tenths of a degree off; a small correcting move keeps nearly the same
  error, which is what lets a head be corrected on its own image.
- **backlash**: a dead band in each axis's gear train (``backlash`` degrees, pan and tilt).
  The output shaft follows the motor only when pushed, so after a reversal the head lags
  the count by the band until the motor has taken it up.

Both are seeded and off unless a URL asks for them (``emu://?pointing_error=0.3&backlash=
0.1&error_seed=7``); the unit still reports its step count, as a real one does.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["HeadErrors"]

_COMPONENTS = 4
"""Sinusoids per axis in the pointing-error field."""
_WAVELENGTH = (30.0, 90.0)
"""Degrees over which one sinusoid of the field repeats (min, max): a tile step apart the
errors are unrelated, a correction apart (tenths of a degree) nearly equal."""


@dataclass(frozen=True)
class HeadErrors:
    """A head's pointing error and backlash (degrees), drawn from ``seed``.

    >>> HeadErrors().enabled, HeadErrors(pointing=0.3).enabled
    (False, True)
    >>> e = HeadErrors(pointing=0.3, seed=7)
    >>> e.offset(10.0, 5.0) == HeadErrors(pointing=0.3, seed=7).offset(10.0, 5.0)
    True
    >>> HeadErrors(backlash=(-0.1, 0.0))
    Traceback (most recent call last):
    ...
    ValueError: head errors are >= 0 degrees, got pointing 0.0, backlash (-0.1, 0.0)
    """

    pointing: float = 0.0
    """Rms pointing error on each axis, degrees."""
    backlash: tuple[float, float] = (0.0, 0.0)
    """Dead band of the pan and tilt gear trains, degrees."""
    seed: int = 0

    def __post_init__(self) -> None:
        if not (self.pointing >= 0.0 and all(b >= 0.0 for b in self.backlash)):
            raise ValueError(
                f"head errors are >= 0 degrees, got pointing {self.pointing}, "
                f"backlash {self.backlash}"
            )

    @property
    def enabled(self) -> bool:
        return self.pointing > 0.0 or any(b > 0.0 for b in self.backlash)

    @functools.cached_property
    def _field(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per axis (rows) and sinusoid (columns): pan and tilt wavenumbers (rad/deg), phase
        and amplitude, scaled so the field's rms is ``pointing``."""
        rng = np.random.default_rng([self.seed, 45])
        shape = (2, _COMPONENTS)
        k = 2.0 * math.pi / rng.uniform(*_WAVELENGTH, shape)
        direction = rng.uniform(0.0, 2.0 * math.pi, shape)
        phase = rng.uniform(0.0, 2.0 * math.pi, shape)
        amplitude = np.full(shape, self.pointing * math.sqrt(2.0 / _COMPONENTS))
        return k * np.cos(direction), k * np.sin(direction), phase, amplitude

    def offset(self, pan: float, tilt: float) -> tuple[float, float]:
        """Pointing error at (pan, tilt) degrees: where the head looks minus where its shafts
        say, degrees (0, 0 when ``pointing`` is 0)."""
        if self.pointing == 0.0:
            return 0.0, 0.0
        kp, kt, phase, amplitude = self._field
        e = (amplitude * np.cos(kp * pan + kt * tilt + phase)).sum(axis=1)
        return float(e[0]), float(e[1])

    @classmethod
    def from_query(cls, query: dict[str, list[str]]) -> HeadErrors:
        """From a PTU URL's query: ``pointing_error`` (rms degrees), ``backlash`` (degrees,
        one for both axes or ``pan,tilt``) and ``error_seed``.

        >>> HeadErrors.from_query({"pointing_error": ["0.3"], "backlash": ["0.1,0.05"]})
        HeadErrors(pointing=0.3, backlash=(0.1, 0.05), seed=0)
        >>> HeadErrors.from_query({"backlash": ["0.1"]}).backlash
        (0.1, 0.1)
        """
        band = [float(v) for v in query.get("backlash", ["0"])[-1].split(",")]
        if len(band) not in (1, 2):
            raise ValueError(f"backlash={query['backlash'][-1]}: want one value or pan,tilt")
        return cls(
            float(query.get("pointing_error", ["0"])[-1]),
            (band[0], band[-1]),
            int(query.get("error_seed", ["0"])[-1]),
        )

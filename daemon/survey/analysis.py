"""A station's analysis as the survey sees it: its profile and settings checked before
anything moves, and the worker's points as the bus carries them (a direction from the
pointing model, an angular size, an azimuth and an elevation).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cyborg.protocol.messages import InterestPoint

from ..pointing.geometry import MosaicGeometry
from ..vision.contract import AnalysisResult
from ..vision.extent import target_radius
from ..vision.params import PROFILES, with_settings
from .site import Orientation

__all__ = ["check_profile", "interest_points"]


def check_profile(profile: str, settings: Sequence[str]) -> None:
    """Raise ValueError for an unknown profile or a bad setting: a typo is an error before
    anything moves, not a failed station later. The aim is no setting here: a station has
    one aim, set as such (``survey.start``'s ``aim``, ``survey.aim``) and recorded once."""
    if profile not in PROFILES:
        raise ValueError(f"unknown profile {profile!r}; known: {', '.join(PROFILES)}")
    if any(item.partition("=")[0].strip() == "aim" for item in settings):
        raise ValueError(
            "settings: the aim is the station's own (--aim, survey.aim), not a setting"
        )
    try:
        with_settings(PROFILES[profile], list(settings))
    except ValueError as exc:
        raise ValueError(f"settings: {exc}") from None


def interest_points(
    analysis: AnalysisResult,
    geometry: MosaicGeometry,
    orientation: Orientation,
    mosaic: np.ndarray,
) -> list[InterestPoint]:
    """The analysed mosaic's points, each with where it lies and how big it looks: its
    angular radius is the one size a target has anywhere (report, advice, the next fit), the
    target's extent measured on ``mosaic`` (``extent.target_radius``) times the mosaic's
    pixel scale."""
    points = []
    for p in analysis.points:
        pan, tilt = geometry.pixel_angles(p.x, p.y)
        points.append(
            InterestPoint(
                p.rank,
                p.x,
                p.y,
                p.score,
                round(pan, 4),
                round(tilt, 4),
                p.description,
                orientation.azimuth(pan),
                orientation.elevation(tilt),
                round(target_radius(mosaic, p.x, p.y, p.radius) * geometry.degrees_per_pixel, 4),
                target=p.target,
            )
        )
    return points

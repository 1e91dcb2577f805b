"""Chip centring: how far a chip's centre truly looks from its target, with and without
refined pointing, on the emulated head with a real head's errors.

Each station is a fresh emulated PTU (pointing error and backlash on, seeded by the
station) under the simulated camera over the detailed world (vignetting, radial distortion
and a drifting auto-exposure on), aimed somewhere new: the real :class:`Acquisition` shoots
its 2x3 mosaic (butted, or registered with ``--overlap``), then chips at three seeded mosaic
points, plainly and then refined (``survey.refine``). The truth is what the emulator knows
and the rig does not: where the head truly looked for each tile (so where a mosaic pixel's
content truly is, through the geometry and the tile's placement) and for each chip. The
error is the angle between a chip's true centre and its target's true place.

Usage: ``python -m bench.chips [--stations 20] [--overlap 0 0.3] [--pointing-error 0.3]
[--backlash 0.1] [--ideal-camera] [--tail]``.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cyborg.daemon.archive import Archive
from cyborg.daemon.camera.base import PoseSource
from cyborg.daemon.camera.simulated import Imperfections, SimulatedCamera
from cyborg.daemon.pointing.geometry import (
    CameraModel,
    MosaicGeometry,
    SphericalMosaic,
    angles_to_pixel,
    pixel_centre,
    pixel_to_angles,
)
from cyborg.daemon.ptu.emulated import EmulatedPtu
from cyborg.daemon.rig import Rig
from cyborg.daemon.sim.camera_effects import radial_undistort
from cyborg.daemon.sim.world import World
from cyborg.daemon.survey.acquire import CHIPS, Acquisition
from cyborg.daemon.survey.refine import CORRECTION_THRESHOLD, separation
from cyborg.protocol.messages import Chip, InterestPoint

HEAD_ERRORS = "pointing_error=0.3&backlash=0.1"
"""A real head's errors, as an emulator URL's query (``ptu.emulator_errors``)."""
CAMERA_FLAWS = Imperfections(vignetting=0.25, k1=-0.05, ae_lag=0.5, ae_walk=0.03)
"""A real camera's, as the simulated camera takes them."""


@dataclass(frozen=True)
class ChipTruth:
    """One chip as published, its true centring error and what the manifest recorded;
    ``first_deg`` is the true error of the first frame taken at the target (the kept one's
    unless it was corrected), ``seam_px`` how far the target lies from the nearest edge of
    the tile its mosaic pixel comes from (mosaic pixels)."""

    chip: Chip
    error_deg: float
    centring: dict[str, object]
    first_deg: float
    seam_px: float
    seed: int
    point: InterestPoint


async def station_chips(
    seed: int,
    *,
    overlap: float = 0.0,
    head_errors: str = HEAD_ERRORS,
    flaws: Imperfections = CAMERA_FLAWS,
) -> tuple[list[ChipTruth], list[ChipTruth]]:
    """Shoot one seeded station's mosaic (butted, or registered with ``overlap``) on the
    emulated head, then its chips plainly and then refined; each chip's true centring
    error, (plain, refined)."""
    rng = np.random.default_rng([seed, 3])
    ptu = EmulatedPtu.from_url(f"emu://?time_scale=100&{head_errors}&error_seed={seed}")
    looked: list[tuple[float, float]] = []

    def recording(pose: PoseSource) -> PoseSource:
        async def where() -> tuple[float, float]:
            looked.append(await pose())
            return looked[-1]

        return where

    camera = CameraModel()
    rig = Rig(
        ptu,
        lambda pose: SimulatedCamera(
            World(seed), camera, pose=recording(pose), seed=seed, imperfections=flaws
        ),
    )
    pan0, tilt0 = float(rng.uniform(-60.0, 60.0)), float(rng.uniform(-8.0, 8.0))
    geometry = MosaicGeometry(camera, 2, 3, pan0, tilt0, 4.0).overlapping(overlap)
    out: tuple[list[ChipTruth], list[ChipTruth]] = ([], [])
    with tempfile.TemporaryDirectory(prefix="bench-chips-") as tmp:
        archive = Archive(Path(tmp), "bench")
        archive.open()
        session = archive.new_session()
        await ptu.open()
        try:
            rig.note(await ptu.position())
            station = archive.new_station(session, 1, 300.0)
            shots = Acquisition(rig, 0.0, {"predicted_motion_s": 0.0, "grab_s": 0.0}, _quiet)
            mosaic, rest = await shots.tiles(station, geometry, 0.0)
            rest()  # the last tile and the mosaic archived
            truth = _Truth(geometry, station.manifest["tiles"], looked, flaws)
            width, height = geometry.size
            points = []
            for rank in range(1, CHIPS + 1):
                x, y = rng.uniform(0.1, 0.9) * width, rng.uniform(0.1, 0.9) * height
                points.append(InterestPoint(rank, x, y, 1.0, *geometry.pixel_angles(x, y)))
            for refined, kept in zip((False, True), out, strict=True):
                chips: list[tuple[Chip, list[tuple[float, float]]]] = []
                start = len(looked)

                def publish(chip: Chip, chips: list = chips) -> None:
                    nonlocal start
                    chips.append((chip, looked[start:]))
                    start = len(looked)

                reference = (mosaic, geometry) if refined else None
                station = archive.new_station(session, 2 + refined, 300.0)
                await shots.chips(station, "bench", points, publish, reference)
                records = {c["rank"]: c.get("centring", {}) for c in station.manifest["chips"]}
                for chip, views in chips:
                    point = points[chip.rank - 1]
                    place, seam = truth.place(point.x, point.y)
                    kept.append(
                        ChipTruth(
                            chip,
                            separation(views[-1], place),
                            records[chip.rank],
                            separation(views[0], place),
                            seam,
                            seed,
                            point,
                        )
                    )
        finally:
            await ptu.close()
    return out


class _Truth:
    """Where a mosaic pixel's content truly is, which the rig cannot know: each tile is in
    the mosaic from the pose it was placed by (butted: its slot; registered: the reported
    pose plus the registration's correction) but was truly shot from where the emulated
    head looked, through the flawed lens. A butted mosaic's pixel comes from the tile in
    whose slot it lies; a registered one's from the covering tile it lies deepest in, the
    likeliest side of a seam."""

    def __init__(
        self,
        geometry: MosaicGeometry,
        tiles: list[dict],
        looked: list[tuple[float, float]],
        flaws: Imperfections,
    ) -> None:
        self.geometry, self.flaws = geometry, flaws
        self.shot = dict(zip(geometry.serpentine(), looked, strict=False))
        self.placed = {}
        for tile in tiles:
            fit = tile.get("registration")
            key = (tile["row"], tile["col"])
            if fit is None:  # butted: in its slot whatever the head reported
                self.placed[key] = geometry.tile_pose(*key)
            else:
                self.placed[key] = (
                    tile["pan"] + fit["dpan_deg"],
                    tile["tilt"] + fit["dtilt_deg"],
                )

    def place(self, x: float, y: float) -> tuple[tuple[float, float], float]:
        """True (pan, tilt) of the content of mosaic pixel (x, y) (analysis counting) and its
        distance from the nearest edge of the tile it comes from, mosaic pixels."""
        cam = self.geometry.camera
        seen = self.geometry.pixel_angles(x, y)
        views = {
            key: tuple(float(v) for v in angles_to_pixel(*seen, *pose, cam))
            for key, pose in self.placed.items()
        }
        if isinstance(self.geometry, SphericalMosaic):
            key = max(views, key=lambda k: _depth(cam, views[k]))
        else:  # the tile in whose slot the pixel lies (tilted frames' edges bow and overlap)
            w, h = self.geometry.tile_size
            key = (int(pixel_centre(y) // h), int(pixel_centre(x) // w))
        px = views[key]
        depth = _depth(cam, px)
        f, cx, cy = cam.focal, cam.width / 2.0, cam.height / 2.0
        u, v = radial_undistort((px[0] - cx) / f, (px[1] - cy) / f, self.flaws.k1, self.flaws.k2)
        a, b = pixel_to_angles(cx + f * u, cy + f * v, *self.shot[key], cam)
        return (float(a), float(b)), depth / self.geometry.downsample


def _depth(cam: CameraModel, xy: tuple[float, float]) -> float:
    """How far inside a frame pixel (x, y) lies, full-resolution pixels (< 0: outside)."""
    x, y = xy
    if not (np.isfinite(x) and np.isfinite(y)):
        return -np.inf
    return min(x, cam.width - x, y, cam.height - y)


def _quiet(*_: object) -> None:
    return None


def centring_errors(
    seeds: range,
    *,
    overlap: float = 0.0,
    head_errors: str = HEAD_ERRORS,
    flaws: Imperfections = CAMERA_FLAWS,
) -> tuple[list[ChipTruth], list[ChipTruth]]:
    """Every chip of every seeded station (:func:`station_chips`), (plain, refined)."""

    async def run() -> tuple[list[ChipTruth], list[ChipTruth]]:
        plain: list[ChipTruth] = []
        refined: list[ChipTruth] = []
        for seed in seeds:
            p, r = await station_chips(seed, overlap=overlap, head_errors=head_errors, flaws=flaws)
            plain += p
            refined += r
        return plain, refined

    return asyncio.run(run())


def summary(chips: list[ChipTruth]) -> dict[str, float]:
    """Median and p95 true centring error (degrees), and the shares within a step,
    corrected, and measured beyond the threshold (what a bare threshold would correct)."""
    errors = sorted(c.error_deg for c in chips)
    return {
        "median_deg": statistics.median(errors),
        "p95_deg": float(np.percentile(errors, 95)),
        "max_deg": errors[-1],
        "within_step": sum(e <= 0.05 for e in errors) / len(errors),
        "corrected": sum(bool(c.centring.get("corrected")) for c in chips) / len(chips),
        "measured_over": sum(
            (c.centring.get("before_deg") or 0.0) > CORRECTION_THRESHOLD for c in chips
        )
        / len(chips),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stations", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--pointing-error", type=float, default=0.3)
    ap.add_argument("--backlash", type=float, default=0.1)
    ap.add_argument("--ideal-camera", action="store_true", help="no camera flaws")
    ap.add_argument(
        "--overlap",
        type=float,
        nargs="+",
        default=[0.0, 0.3],
        help="mosaics to refine on: 0 butted, > 0 registered with that overlap",
    )
    ap.add_argument("--tail", action="store_true", help="list refined chips beyond a step")
    args = ap.parse_args(argv)
    errors = f"pointing_error={args.pointing_error}&backlash={args.backlash}"
    flaws = Imperfections() if args.ideal_camera else CAMERA_FLAWS
    seeds = range(args.first_seed, args.first_seed + args.stations)
    print(f"chip centring, seeds {seeds.start}..{seeds.stop - 1} x {CHIPS} chips, head {errors}")
    print(f"camera {flaws}")
    print(f"{'mosaic':16} {'chips':10} {'median deg':>10} {'p95 deg':>8} {'max deg':>8}", end="")
    print(f" {'<=0.05':>7} {'corrected':>9} {'measured>0.05':>13}")
    for overlap in args.overlap:
        name = f"registered {overlap:g}" if overlap else "butted"
        both = centring_errors(seeds, overlap=overlap, head_errors=errors, flaws=flaws)
        for label, chips in zip(("unrefined", "refined"), both, strict=True):
            s = summary(chips)
            print(
                f"{name:16} {label:10} {s['median_deg']:10.3f} {s['p95_deg']:8.3f} "
                f"{s['max_deg']:8.3f} {s['within_step']:7.0%} {s['corrected']:9.0%} "
                f"{s['measured_over']:13.0%}"
            )
        for c in both[1] if args.tail else ():
            if c.error_deg > 0.05:
                print(
                    f"  tail: seed {c.seed} rank {c.chip.rank} true {c.error_deg:.3f} "
                    f"first {c.first_deg:.3f} seam {c.seam_px:.1f} px, recorded {c.centring}"
                )
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

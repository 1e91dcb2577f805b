"""Registered mosaics: seams and the science on them, butted against projected and registered.

Each scene is a seeded target-free cliff (``camera.simulated.outcrop_panorama`` with no
planted targets) seen through the simulated camera with a real camera's flaws and an
emulated PTU with a real head's errors (``bench.chips``'s: 0.3° rms pointing error, 0.1°
backlash; vignetting, barrel distortion, a drifting auto-exposure), seeded by the scene.
The same head shoots each scene twice: a butted 2x3 mosaic (the seed's) and one overlapping
by ``--overlap``, which is composed twice, from the recorded poses only and registered
(``survey.stitch``). The truth is what the emulator knows and the rig does not: where the
head truly looked for each tile.

- **seam residual**: for two adjacent tiles, the angle between the directions each shows at
  the same mosaic pixel (along the shared edge when butted, over the overlap otherwise), in
  mosaic pixels; per pair the median, then the median and p95 over pairs.
- **top-3 on a seam**: the share of mosaics where one of the ``default`` profile's first
  three points lies within ``SEAM_PX`` of a seam: where the pixels' tile changes (the
  butted grid's lines; the seam finder's cuts), with the share of the mosaic such bands
  cover for scale (the rate a point dropped at random would have), and the share of all
  top-3 points on a seam (against that band share: above it, seams draw the science).
- **registered** goes through the survey's loop: composed, analysed, and while a top-3
  point is near a seam (``Stitcher.keep_off``, at most ``KEEP_OFF_ROUNDS`` times) the seams
  are cut again around every point found so far, and the mosaic composed and analysed
  again; judged on the last mosaic and its seams. **reg. 1st pass** is its first mosaic
  and seams, before any re-cut.
- **seamless**: the floor. The same world drawn straight onto the registered canvas (one
  flawless frame, no seams, no-data where the mosaic has none) and judged on the registered
  mosaic's (last) seam bands: how often the world alone puts a top-3 point there. With
  bands ``2 * SEAM_PX`` wide covering ~6 % of a 2x3 mosaic, three points land on one by
  chance in about 1 - 0.94^3 = 17 % of mosaics.
- **reg. as shot**: registered without the flat field (``Stitcher(flatten=False)``): each
  frame's vignetting left in, a step at every seam the gains cannot take off.
- **compose**: CPU seconds to register and compose a mosaic (the first time); the re-cuts
  line gives how many mosaics needed one and the CPU milliseconds of a ``keep_off`` call
  (one that re-cut, one that did not), of composing again and of the analysis.
- **no-data**: in how many registered mosaics some pixels no frame covers (exact:
  ``stitch.uncovered``) are missed by the science's own no-data rule (``vision.nodata``:
  fill connected to the edge and at least 0.25 % of the view), and how many pixels.

Chip centring with and without refined pointing is ``bench.chips``; a station's wall time
against the motion-plus-grab bound is ``bench.survey`` (run with ``overlap`` set).

Usage: ``python -m bench.mosaic [--scenes 20] [--first-seed 0] [--overlap 0.3] [--dump DIR]``.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from bench.chips import CAMERA_FLAWS, HEAD_ERRORS
from bench.stats import wilson
from cyborg.daemon.camera.simulated import Panorama, SimulatedCamera, outcrop_panorama
from cyborg.daemon.pointing.geometry import (
    CameraModel,
    MosaicGeometry,
    SphericalMosaic,
    angles_to_pixel,
    pixel_index,
    pixel_to_angles,
)
from cyborg.daemon.ptu.emulated import EmulatedPtu
from cyborg.daemon.sim.camera_effects import radial_undistort
from cyborg.daemon.survey.stitch import KEEP_OFF_ROUNDS, Stitcher, uncovered
from cyborg.daemon.vision.interest import InterestPoint
from cyborg.daemon.vision.job import analyze_image, input_points
from cyborg.daemon.vision.nodata import no_data_mask
from cyborg.daemon.vision.params import profile

CAMERA = CameraModel(720, 576, 30.0)
DOWNSAMPLE = 4.0
SEAM_PX = 3
"""Mosaic pixels either side of a seam that count as on it."""
TOP = 3


@dataclass(frozen=True)
class Shot:
    row: int
    col: int
    image: np.ndarray
    recorded: tuple[float, float]
    true: tuple[float, float]


async def _shoot(panorama: Panorama, geometry: MosaicGeometry, seed: int) -> list[Shot]:
    """Every tile of ``geometry`` as the flawed head and camera of scene ``seed`` shoot it."""
    ptu = EmulatedPtu.from_url(f"emu://?time_scale=1000&{HEAD_ERRORS}&error_seed={seed}")
    await ptu.open()
    camera = SimulatedCamera(
        panorama, CAMERA, pose=ptu.true_pose, seed=seed, imperfections=CAMERA_FLAWS
    )
    shots = []
    try:
        for row, col in geometry.serpentine():
            here = await ptu.move_to(*geometry.tile_pose(row, col))
            true = await ptu.true_pose()
            frame = await camera.grab()
            shots.append(Shot(row, col, frame.image, (here.pan, here.tilt), true))
    finally:
        await ptu.close()
    return shots


def _true_angles(x, y, pose: tuple[float, float]):
    """World (pan, tilt) a pixel of a frame truly shows: its lens's distortion undone, seen
    from where the head truly was."""
    f, cx, cy = CAMERA.focal, CAMERA.width / 2.0, CAMERA.height / 2.0
    u, v = radial_undistort((x - cx) / f, (y - cy) / f, CAMERA_FLAWS.k1, CAMERA_FLAWS.k2)
    return pixel_to_angles(cx + f * u, cy + f * v, *pose, CAMERA)


def _apart(a, b, degrees_per_pixel: float) -> np.ndarray:
    """Angle between directions ``a`` and ``b`` ((pan, tilt) arrays), mosaic pixels."""
    dpan = (a[0] - b[0]) * np.cos(np.radians(a[1]))
    return np.hypot(dpan, a[1] - b[1]) / degrees_per_pixel


def _pairs(shots: list[Shot]) -> list[tuple[Shot, Shot]]:
    return [
        (s, t)
        for s in shots
        for t in shots
        if (t.row, t.col) in ((s.row, s.col + 1), (s.row + 1, s.col))
    ]


def _butted(shots: list[Shot], g: MosaicGeometry) -> tuple[np.ndarray, list[float], np.ndarray]:
    """The butted mosaic, each seam's residual and the seam bands."""
    w, h = g.tile_size
    mosaic = np.zeros((g.size[1], g.size[0], 3), np.uint8)
    for s in shots:
        small = cv2.resize(s.image, (w, h), interpolation=cv2.INTER_AREA)
        mosaic[s.row * h : (s.row + 1) * h, s.col * w : (s.col + 1) * w] = small
    along = np.linspace(0.0, 1.0, 65)
    residuals = []
    for s, t in _pairs(shots):
        if t.col > s.col:  # s's right edge against t's left
            ys = along * CAMERA.height
            edge_s, edge_t = (np.full_like(ys, CAMERA.width), ys), (np.zeros_like(ys), ys)
        else:
            xs = along * CAMERA.width
            edge_s, edge_t = (xs, np.full_like(xs, CAMERA.height)), (xs, np.zeros_like(xs))
        a, b = _true_angles(*edge_s, s.true), _true_angles(*edge_t, t.true)
        residuals.append(float(np.median(_apart(a, b, g.degrees_per_pixel))))
    band = np.zeros(mosaic.shape[:2], bool)
    for c in range(1, g.cols):
        band[:, c * w - SEAM_PX : c * w + SEAM_PX] = True
    for r in range(1, g.rows):
        band[r * h - SEAM_PX : r * h + SEAM_PX, :] = True
    return mosaic, residuals, band


def _canvas_angles(g: SphericalMosaic, fine: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """World (pan, tilt) degrees of the canvas's pixel centres, ``fine`` samples a pixel
    each way (``fine`` x its size)."""
    (u0, v0), (width, height) = g.origin, g.size
    j = (np.arange(width * fine) + 0.5) / fine - 0.5
    i = (np.arange(height * fine) + 0.5) / fine - 0.5
    pan = np.degrees((u0 + j) / g.scale)[None, :]
    tilt = np.degrees(math.pi / 2 - (v0 + i) / g.scale)[:, None]
    return np.broadcast_arrays(pan, tilt)


def _seamless(panorama: Panorama, g: SphericalMosaic, covered: np.ndarray) -> np.ndarray:
    """The world straight onto the canvas, as one flawless frame would show it (sampled
    ``DOWNSAMPLE`` times finer and reduced, as the frames are), black where ``covered`` is
    false: what the science sees there without a seam."""
    px, py = panorama.to_pixel(*_canvas_angles(g, round(DOWNSAMPLE)))
    fine = cv2.remap(
        panorama.image,
        pixel_index(px).astype(np.float32),
        pixel_index(py).astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    image = cv2.resize(fine, g.size, interpolation=cv2.INTER_AREA)
    image[~covered] = 0
    return image


def _projected(
    shots: list[Shot], g: SphericalMosaic, register: bool, flatten: bool = True
) -> tuple[Stitcher, np.ndarray, list[float], float]:
    """The overlapping mosaic from the recorded poses, registered or not, flat-fielded or
    not: its stitcher, the mosaic, each seam's residual and the CPU seconds it took."""
    t0 = time.process_time()
    stitcher = Stitcher(g, register=register, flatten=flatten)
    placed = {}
    for s in shots:
        placed[s.row, s.col] = stitcher.add(s.row, s.col, s.image, s.recorded).placed
    mosaic = stitcher.compose()
    cpu = time.process_time() - t0
    pan, tilt = _canvas_angles(g)
    pixels, inside = {}, {}
    for s in shots:
        x, y = angles_to_pixel(pan, tilt, *placed[s.row, s.col], CAMERA)
        pixels[s.row, s.col] = (x, y)
        inside[s.row, s.col] = (x >= 0) & (x < CAMERA.width) & (y >= 0) & (y < CAMERA.height)
    residuals = []
    for s, t in _pairs(shots):
        both = inside[s.row, s.col] & inside[t.row, t.col]
        xs, ys = (v[both] for v in pixels[s.row, s.col])
        xt, yt = (v[both] for v in pixels[t.row, t.col])
        a, b = _true_angles(xs, ys, s.true), _true_angles(xt, yt, t.true)
        residuals.append(float(np.median(_apart(a, b, g.degrees_per_pixel))))
    return stitcher, mosaic, residuals, cpu


def _band(owners: np.ndarray) -> np.ndarray:
    """The seam bands of a stitched mosaic's ``owners``: within ``SEAM_PX`` of where the
    tile changes."""
    owners = owners.astype(np.float32)
    kernel = np.ones((2 * SEAM_PX + 1, 2 * SEAM_PX + 1), np.uint8)
    band = (cv2.dilate(owners, kernel) != cv2.erode(owners, kernel)) & (owners >= 0)
    band &= cv2.erode(owners, kernel) >= 0  # where tiles meet, not the edge of the no-data
    return band


def _top(mosaic: np.ndarray, cpu: list[float] | None = None) -> list[InterestPoint]:
    """The ``default`` profile's first points on ``mosaic`` (its CPU seconds to ``cpu``)."""
    t0 = time.process_time()
    bgr, res = analyze_image(mosaic, profile("default"))
    if cpu is not None:
        cpu.append(time.process_time() - t0)
    return input_points(bgr.shape, res)[:TOP]


def _keep_off(
    stitcher: Stitcher, mosaic: np.ndarray, points: list[InterestPoint], cpu: dict[str, list]
) -> tuple[np.ndarray, list[InterestPoint], int]:
    """The survey's loop: while a seam passes near a top point (at most ``KEEP_OFF_ROUNDS``
    times), cut the seams off every point found so far, compose and analyse again. The last
    mosaic, its points and how many re-cuts it took; CPU seconds go to ``cpu``."""
    kept = [(p.x, p.y) for p in points]
    rounds = 0
    for _ in range(KEEP_OFF_ROUNDS):
        t0 = time.process_time()
        moved = stitcher.keep_off(kept)
        cpu["keep_off" if moved else "kept off"].append(time.process_time() - t0)
        if not moved:
            break
        t0 = time.process_time()
        mosaic = stitcher.compose()
        cpu["compose"].append(time.process_time() - t0)
        points = _top(mosaic, cpu["analysis"])
        kept = [(p.x, p.y) for p in points] + kept  # the latest points first
        rounds += 1
    return mosaic, points, rounds


def _on_seam(
    mosaic: np.ndarray,
    band: np.ndarray,
    points: list[InterestPoint],
    dump: Path | None = None,
) -> int:
    """How many of ``points`` lie on a seam band; when one does and ``dump`` is given, the
    mosaic is written there with the band and points drawn."""
    on = sum(
        0 <= round(p.y) < band.shape[0]
        and 0 <= round(p.x) < band.shape[1]
        and bool(band[round(p.y), round(p.x)])
        for p in points
    )
    if on and dump is not None:
        shown = mosaic.copy()
        shown[band] = (shown[band] // 2 + (0, 0, 127)).astype(np.uint8)
        for k, p in enumerate(points):
            cv2.circle(shown, (round(p.x), round(p.y)), 6, (0, 255, 255), 1)
            cv2.putText(shown, str(k + 1), (round(p.x) + 7, round(p.y)), 0, 0.4, (0, 255, 255))
        cv2.imwrite(str(dump), cv2.resize(shown, None, fx=3, fy=3, interpolation=cv2.INTER_NEAREST))
    return on


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.mosaic", description=__doc__)
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--overlap", type=float, default=0.3)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--dump", type=Path, help="write mosaics with a top-3 point on a seam here")
    args = ap.parse_args(argv)
    if args.dump is not None:
        args.dump.mkdir(parents=True, exist_ok=True)
    butted = MosaicGeometry(CAMERA, 2, 3, 0.0, 0.0, DOWNSAMPLE)
    overlapping = butted.overlapping(args.overlap)
    projected = {  # name: (register, flatten)
        "pose only": (False, True),
        "reg. as shot": (True, False),
        "registered": (True, True),
    }
    methods = ("butted", "pose only", "reg. as shot", "reg. 1st pass", "registered", "seamless")
    residuals: dict[str, list[float]] = {m: [] for m in methods}
    hits, points = dict.fromkeys(methods, 0), dict.fromkeys(methods, 0)
    share: dict[str, list[float]] = {m: [] for m in methods}
    cpu: dict[str, list[float]] = {m: [] for m in projected}
    recut: dict[str, list[float]] = {k: [] for k in ("keep_off", "kept off", "compose", "analysis")}
    rounds = [0] * (KEEP_OFF_ROUNDS + 1)
    void = {"mosaics": 0, "missed in": 0, "pixels": 0, "missed": 0}
    for seed in range(args.first_seed, args.first_seed + args.scenes):
        panorama = outcrop_panorama(seed, n_targets=0)
        mosaic, res, band = _butted(asyncio.run(_shoot(panorama, butted, seed)), butted)
        results = {"butted": (mosaic, res, band, _top(mosaic))}
        shots = asyncio.run(_shoot(panorama, overlapping, seed))
        for name, (register, flatten) in projected.items():
            stitcher, mosaic, res, seconds = _projected(shots, overlapping, register, flatten)
            cpu[name].append(seconds)
            top = _top(mosaic, recut["analysis"] if name == "registered" else None)
            if name == "registered":
                results["reg. 1st pass"] = (mosaic, res, _band(stitcher.owners), top)
                mosaic, top, n_recut = _keep_off(stitcher, mosaic, top, recut)
                rounds[n_recut] += 1
                covered = stitcher.owners >= 0
            results[name] = (mosaic, res, _band(stitcher.owners), top)
        gap = uncovered(results["registered"][0])
        found = no_data_mask(results["registered"][0])
        missed = gap if found is None else gap & ~found
        void["mosaics"] += bool(gap.any())
        void["missed in"] += bool(missed.any())
        void["pixels"] += int(gap.sum())
        void["missed"] += int(missed.sum())
        # The floor: the registered mosaic's seams over the same world without them.
        seamless = _seamless(panorama, overlapping, covered)
        results["seamless"] = (seamless, [], results["registered"][2], _top(seamless))
        for name in methods:
            mosaic, res, band, top = results[name]
            if name != "reg. 1st pass":  # its seams are the registered one's
                residuals[name].extend(res)
            share[name].append(float(band.mean()))
            dump = None if args.dump is None else args.dump / f"{seed}-{name.replace(' ', '-')}.png"
            on = _on_seam(mosaic, band, top, dump)
            hits[name] += on > 0
            points[name] += on
        print(
            f"scene {seed}: "
            + ", ".join(f"{m} {max(results[m][1]):.2f}" for m in ("butted", *projected)),
            "px worst seam",
            file=sys.stderr,
        )
    n = max(args.scenes, 1)
    print(
        f"{args.scenes} target-free scenes (seeds {args.first_seed}+), 2x3 mosaics (overlap "
        f"{args.overlap:g} when projected), head {HEAD_ERRORS}, camera {CAMERA_FLAWS}"
    )
    print(
        f"{'mosaic':<12} {'seam px median':>14} {'p95':>5} {'top-3 on seam':>14} "
        f"{'95 % interval':>12} {'points on seam':>14} {'95 % interval':>12} {'seam share':>10} "
        f"{'compose cpu s':>13}"
    )
    for m in methods:
        r = np.asarray(residuals[m])
        seam = (
            f"{np.median(r):14.2f} {np.percentile(r, 95):5.2f}" if r.size else f"{'-':>14} {'-':>5}"
        )
        seconds = f"{statistics.median(cpu[m]):13.3f}" if m in cpu else f"{'-':>13}"
        rates = []
        for k, of in ((hits[m], n), (points[m], TOP * n)):
            low, high = wilson(k / of, of)
            rates.append(f"{k:>3}/{of:<3} {k / of:6.1%} {f'{low:.1%}-{high:.1%}':>12}")
        print(f"{m:<12} {seam} {rates[0]} {rates[1]} {statistics.mean(share[m]):10.1%} {seconds}")
    print(
        "seamless: the same world drawn straight onto the canvas, judged on the registered "
        "mosaic's last seams (the rate the world alone gives); points on seam: the share of all "
        "top-3 points there, to compare with the seam share (what chance gives)"
    )
    ms = {k: 1000 * statistics.median(v) if v else math.nan for k, v in recut.items()}
    print(
        f"re-cuts (registered): {n - rounds[0]}/{n} mosaics had a seam near a top-3 point "
        f"({rounds[-1]} of them {KEEP_OFF_ROUNDS} times); CPU ms median: keep_off "
        f"{ms['keep_off']:.0f} when it re-cut, {ms['kept off']:.1f} when not; compose again "
        f"{ms['compose']:.0f}; analysis {ms['analysis']:.0f}"
    )
    print(
        f"no-data (registered): {void['mosaics']}/{n} mosaics have pixels no frame covers "
        f"({void['pixels']} px); the science's own rule misses them in {void['missed in']}/{n} "
        f"({void['missed']} px, {void['missed'] / max(void['pixels'], 1):.0%})"
    )
    print("goals with registration: seam median <= 1 px, p95 <= 2 px; top-3 on a seam in <= 2 %")
    return 0


if __name__ == "__main__":
    sys.exit(main())

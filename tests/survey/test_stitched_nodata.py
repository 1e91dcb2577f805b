"""A registered mosaic's no-data is known exactly (black there and nowhere else) and memory
takes it for what it is: ground no frame showed, neither a colour nor common ground carried
to the closer station."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from cyborg.daemon.archive import Archive
from cyborg.daemon.camera.simulated import PAN, TILT, Panorama, SimulatedCamera
from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry, SphericalMosaic
from cyborg.daemon.survey.approach import Previous
from cyborg.daemon.survey.memory import DISTINCT, SessionMemory, distinctness, lab_image
from cyborg.daemon.survey.stitch import Stitcher, no_data, uncovered
from cyborg.daemon.vision.contract import AnalysisJob
from cyborg.daemon.vision.job import analyse_into, analyze_image
from cyborg.daemon.vision.params import profile
from tests.survey.test_stitch import _errors, _stitch

CAM = CameraModel(720, 576, 30.0)
WEIGHT = 0.8


async def _corner_missed(right: float = 1.9) -> tuple[SphericalMosaic, Stitcher, np.ndarray]:
    """A 2×3 registered mosaic whose bottom-left tile, shot ``right``° right of where the
    head reports, leaves the canvas's bottom-left corner uncovered."""
    camera = SimulatedCamera.from_url("sim://outcrop?seed=3&noise=2")
    g = SphericalMosaic(CAM, 2, 3, 0.0, 3.0, 4.0, overlap=0.3)
    errors = _errors(6, 5)
    errors[-1] = (right, 0.3)
    stitcher, mosaic = await _stitch(camera, g, errors)
    return g, stitcher, mosaic


async def test_black_is_what_no_frame_covers_and_nothing_else() -> None:
    """A shadow the camera crushed to one grey level, which gains and blending took to pure
    black on a third of the canvas, is lifted off it: the mosaic itself (and its lossless
    PNG) says exactly where no frame reached."""
    g, stitcher, mosaic = await _corner_missed()
    void = uncovered(mosaic)
    np.testing.assert_array_equal(void, stitcher.owners < 0)
    assert void.any() and not void.all()
    crushed = np.full((CAM.height, CAM.width, 3), 140, np.uint8)
    crushed[:, CAM.width // 2 :] = 1
    dark = Stitcher(g, register=False, flatten=False)
    for row, col in g.serpentine():
        dark.add(row, col, crushed, g.tile_pose(row, col))
    shown = dark.compose()
    assert (dark.owners >= 0).all()
    assert not uncovered(shown).any()


async def test_memory_carries_no_data_as_ground_not_seen(tmp_path: Path) -> None:
    """The earlier station's interest where its mosaic had no data is no judgement: the
    closer station weighs that ground as ground the earlier one did not see (``judged`` 1,
    a quarter of the favour with no palette), not at the level the science scored the fill."""
    g, _, mosaic = await _corner_missed()
    archive = Archive(tmp_path, "test")
    archive.open()
    session = archive.new_session()
    station = archive.new_station(session, 1, 300.0, plan=g.to_plan(profile="default"))
    station.write_png("mosaic.png", mosaic)
    analyse_into(AnalysisJob(str(station.partial_dir), mosaic, "default", "mosaic.png"))
    station.publish_analysis()
    far = (g.pan0 + 90.0, g.tilt0)  # the chosen target well outside the view: no favour
    previous = Previous(f"{session}/{station.name}", far, 1.0, 1.0)
    prior, record = SessionMemory().prior(previous, archive, g, mosaic, WEIGHT)
    assert prior is not None and record == {"from": previous.station, "weight": WEIGHT}
    rows, cols = prior.shape
    share = cv2.resize(uncovered(mosaic).astype(np.float32), (cols, rows), cv2.INTER_AREA)
    unseen = 1.0 - WEIGHT + WEIGHT * 0.25
    assert (share == 1.0).any()
    np.testing.assert_allclose(prior[share == 1.0], unseen, atol=1e-6)
    assert prior[share == 0.0].min() < unseen  # where it saw, it judged


async def test_no_data_is_no_colour_and_no_surround() -> None:
    """Known answer: on plain rock a patch by an uncovered corner is not distinct at all (its
    surround reaches into the corner's black, which is no surround); the palette holds no
    black the outcrop did not have."""
    plain = Panorama(np.full((1248, 2400, 3), 128, np.uint8), PAN, TILT)
    camera = SimulatedCamera(plain, CAM, noise=2.0, seed=3)
    g = SphericalMosaic(CAM, 2, 3, 0.0, 3.0, 4.0, overlap=0.3)
    stitcher = Stitcher(g, register=False)
    for row, col in g.serpentine():  # the last tile placed 1.9° right: the corner uncovered
        camera.fixed_pose = pose = g.tile_pose(row, col)
        placed = (pose[0] + 1.9, pose[1]) if (row, col) == (1, 0) else pose
        stitcher.add(row, col, (await camera.grab()).image, placed)
    mosaic = stitcher.compose()
    void = uncovered(mosaic)
    ys, xs = np.nonzero(void)
    x, y = float(xs.max()) + 2.0, float(ys.max())  # beside the corner
    lab = lab_image(mosaic, g)
    assert np.isnan(lab[void]).all() and not np.isnan(lab[~void]).any()
    assert (
        distinctness(lab, x, y, 4.0) < 1.0 < DISTINCT < distinctness(lab_image(mosaic), x, y, 4.0)
    )
    memory = SessionMemory()
    memory.remember("s/st01-300m", mosaic, g, [], None)
    (palette,) = memory.palettes()
    assert palette[:, 0].min() > 40.0  # the rock's grey, no L* of black


async def test_the_science_leaves_out_every_uncovered_pixel(tmp_path: Path) -> None:
    """The uncovered corner is too small for the science's own fill rule (a speck under its
    floor), so it would be judged as a black patch; the station hands the stitcher's exact
    coverage on (``stitch.no_data``) and the analysis leaves all of it out and says so."""
    g, _, mosaic = await _corner_missed(1.3)  # 0.3 % of the canvas, in the corner
    void = no_data(mosaic, g)
    assert void is not None and void.any()
    assert no_data(mosaic, MosaicGeometry(CAM, 2, 3, 0.0, 3.0, 4.0)) is None  # butted black
    found = analyze_image(mosaic, profile("default"))[1]
    assert not any("no-data" in n for n in found.notes)  # the floor misses the speck
    told = analyze_image(mosaic, profile("default"), no_data=void)[1]
    assert any("no-data" in n for n in told.notes)
    rows, cols = told.hsi.i.shape
    reduced = cv2.resize(void.astype(np.float32), (cols, rows), interpolation=cv2.INTER_AREA)
    assert told.no_data is not None and told.no_data[reduced == 1.0].all()
    for seg in told.segmentations:  # no class holds a pixel of it (0: unsegmented)
        assert not seg.labels[reduced == 1.0].any()
    result = analyse_into(AnalysisJob(str(tmp_path), mosaic, "default", "mosaic.png", no_data=void))
    assert any("no-data" in n for n in result.notes)

"""The survey engine in-process (emulated PTU, simulated camera, a real worker process):
a full disk and a camera that fails mid-survey fail the station cleanly and keep what
was written; a station cancelled while its products are drawn gets them drawn again."""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import errno
import json
import os
import re
import signal
from pathlib import Path
from typing import Any

import pytest

import cyborg.daemon.archive as archive_mod
from cyborg.daemon.archive import Archive
from cyborg.daemon.camera import CameraError, open_camera
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.ptu import open_ptu
from cyborg.daemon.rig import Rig
from cyborg.daemon.survey import Survey, SurveyTelemetry
from cyborg.daemon.survey.memory import NEW
from cyborg.daemon.worker import VisionWorker
from cyborg.protocol.messages import ChooseTarget, SurveyStart

pytestmark = pytest.mark.timeout(120)


class Recorder:
    def __init__(self) -> None:
        self.progress, self.results, self.chips, self.events = [], [], [], []

    def telemetry(self) -> SurveyTelemetry:
        return SurveyTelemetry(
            self.progress.append,
            self.results.append,
            self.chips.append,
            lambda level, text: self.events.append((level, text)),
        )


@contextlib.asynccontextmanager
async def _engine(
    tmp_path: Path,
    config: SurveyConfig | None = None,
    camera: str = "sim://outcrop?seed=3",
    head: str = "emu://?time_scale=50",
    **where: Any,
):
    """A survey engine on the emulated PTU (or ``head``), the simulated outcrop (or
    ``camera``) and a real worker; ``where`` (orientation, site) says where it stands."""
    ptu = open_ptu(head)
    rig = Rig(ptu, lambda pose: open_camera(camera, pose=pose))
    async with VisionWorker() as worker:
        await ptu.open()
        rec = Recorder()
        archive = Archive(tmp_path / "archive", "t")
        archive.open()
        config = config or SurveyConfig()
        survey = Survey(rig, worker, archive, config, hfov=30.0, telemetry=rec.telemetry(), **where)
        try:
            yield survey, rec, archive
        finally:
            await survey.stop("test over")
            await ptu.close()


@pytest.fixture
async def engine(tmp_path: Path):
    async with _engine(tmp_path) as parts:
        yield parts


class DiskFull:
    """The disk fills up after ``images`` PNG files; with ``everything``, the manifest
    updates fail from then on too."""

    def __init__(self, images: int, everything: bool) -> None:
        self.images, self.everything = images, everything
        self.png, self.atomic = archive_mod.write_png, archive_mod.write_atomic
        self.written = 0

    def _refuse(self, path: Path) -> None:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    def write_png(self, path: Path, image) -> None:
        if self.written >= self.images:
            self._refuse(path)
        self.written += 1
        self.png(path, image)

    def write_atomic(self, path: Path, data: bytes) -> None:
        if self.everything and self.written >= self.images:
            self._refuse(path)
        self.atomic(path, data)


@pytest.mark.parametrize("everything", [False, True], ids=["images", "everything"])
async def test_full_disk_fails_the_station_and_keeps_what_was_written(
    engine, monkeypatch, everything: bool
) -> None:
    survey, rec, archive = engine
    disk = DiskFull(3, everything)
    monkeypatch.setattr(archive_mod, "write_png", disk.write_png)
    monkeypatch.setattr(archive_mod, "write_atomic", disk.write_atomic)
    survey.start(SurveyStart(rows=2, cols=3), "tester")
    await survey._task
    folder = survey.station.folder
    m = json.loads((folder / "manifest.json").read_text())
    listed = ["tiles/r0c0.png", "tiles/r0c1.png", "tiles/r0c2.png"]
    # With everything refused, the manifest update after the third tile failed too: the
    # tile is on disk but unlisted, and the manifest stays true to what it lists.
    assert [t["file"] for t in m["tiles"]] == listed[: 2 if everything else 3]
    for rel, size in m["files"].items():
        assert (folder / rel).stat().st_size == size
    assert not [p for p in folder.rglob(".*") if p.name != "manifest.json"]
    if everything:
        assert m["status"] == "in-progress"  # the disk refused even the last word...
        monkeypatch.undo()
        assert archive.open() == [f"{folder.parent.name}/{folder.name}"]  # ...fixed at start
        m = json.loads((folder / "manifest.json").read_text())
        assert m["status"] == "incomplete"
    else:
        assert m["status"] == "failed"
        assert "No space left on device" in m["reason"] and "r1c2.png" in m["reason"]
    assert rec.events[-1][0] == "error" and "No space left on device" in rec.events[-1][1]
    assert rec.progress[-1].stage == "failed" and survey.state == "idle"
    # The disk is freed: the next station works.
    monkeypatch.undo()
    survey.start(SurveyStart(rows=1, cols=2), "tester")
    await survey._task
    assert survey.state == "awaiting-choice" and len(rec.results) == 1


async def test_a_station_cancelled_while_its_products_are_drawn_gets_them_drawn_again(
    engine,
) -> None:
    survey, rec, _ = engine
    survey.start(SurveyStart(rows=2, cols=3, downsample=1.0), "tester")  # slow products
    async with asyncio.timeout(60):
        while not any(p.stage == "chips" for p in rec.progress):
            await asyncio.sleep(0.01)
    drawer = survey.worker.pid
    os.kill(drawer, signal.SIGSTOP)  # the drawing cannot finish before the cancel
    try:
        assert await survey.cancel("the scientist cancels")
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(drawer, signal.SIGCONT)
    assert survey.worker.pid not in (0, drawer)  # the drawing's worker was replaced
    folder = survey.station.folder
    assert "products" not in json.loads((folder / "manifest.json").read_text())
    await survey.stop("the daemon is stopping")  # waits for the products drawn again
    m = json.loads((folder / "manifest.json").read_text())
    assert m["status"] == "incomplete" and m["points"]
    assert m["products"]["overlay"] == "overlay.png" and (folder / "analysis/overlay.png").exists()
    assert not (folder / ".analysis.partial").exists()
    for rel, size in m["files"].items():
        assert (folder / rel).stat().st_size == size, rel
    assert ("info", f"station {survey.station_id}: its products were drawn after it ended") in (
        rec.events
    )


async def test_camera_failure_mid_survey_fails_the_station(engine, monkeypatch) -> None:
    survey, _, _ = engine
    camera = survey.rig.camera
    real_grab, grabs = camera.grab, []

    async def flaky():
        grabs.append(1)
        if len(grabs) == 3:
            raise CameraError("sim camera: frame unreadable")
        return await real_grab()

    monkeypatch.setattr(camera, "grab", flaky)
    survey.start(SurveyStart(rows=2, cols=3), "tester")
    await survey._task
    m = survey.station.manifest
    assert m["status"] == "failed" and "frame unreadable" in m["reason"]
    assert len(m["tiles"]) == 2


async def test_plan_outside_the_limits_is_refused_before_moving(engine) -> None:
    survey, _, archive = engine
    from cyborg.daemon.ptu import PtuLimitError  # noqa: PLC0415

    with pytest.raises(PtuLimitError, match="outside the unit's limits"):
        survey.start(SurveyStart(rows=4, cols=3, tilt0=20.0), "tester")
    assert archive.sessions() == [] and survey.state == "idle"


async def test_a_survey_is_centred_by_decision_not_where_the_head_stopped(engine) -> None:
    """Chips leave the head at the last point; a survey asked again without a centre is
    shot where the last one was (and the first where the rig was set up to face)."""
    survey, _, _ = engine
    survey.start(SurveyStart(rows=1, cols=2), "tester")
    await survey._task
    assert (survey.station.manifest["plan"]["pan0"], survey.station.manifest["plan"]["tilt0"]) == (
        0.0,
        0.0,
    )
    survey.start(SurveyStart(rows=1, cols=2, pan0=10.0, tilt0=2.0), "tester")
    await survey._task
    here = survey.rig.pose
    assert (here.pan, here.tilt) != pytest.approx((10.0, 2.0), abs=0.5)  # at a chip
    survey.start(SurveyStart(rows=1, cols=2), "tester")
    await survey._task
    plan = survey.station.manifest["plan"]
    assert (plan["pan0"], plan["tilt0"]) == (10.0, 2.0)


async def test_the_next_station_is_aimed_and_sized_by_the_target(tmp_path: Path) -> None:
    """A point carries its angular size; choosing it plans the next mosaic around it (three
    target diameters each way, at most the configured mosaic) and says where to stand for
    it to fill a third of the view. (On the world: a walked mosaic aimed near a panorama's
    edge would leave it, and is refused.)"""
    async with _engine(tmp_path, camera="sim://world?seed=3") as (survey, _, _):
        survey.start(SurveyStart(rows=2, cols=3), "tester")
        await survey._task
        result = survey._result
        best = result.points[0]
        assert best.radius_deg and best.radius_deg > 0
        ack = await survey.choose(ChooseTarget(result.station, 1), "tester")
        fit = survey.station.manifest["choice"]["next"]
        assert "across" in ack and f"{fit['rows']}×{fit['cols']} mosaic" in ack
        assert fit["target_deg"] == pytest.approx(2 * best.radius_deg * 300 / 60, rel=1e-3)
        assert fit["suggested_m"] == pytest.approx(300 * 2 * best.radius_deg / 10.0, rel=1e-2)
        assert 1 <= fit["rows"] <= 2 and 1 <= fit["cols"] <= 3
        survey.start(SurveyStart(), "tester")  # no size asked: the fitted one
        plan = survey.station.manifest["plan"]
        assert (plan["rows"], plan["cols"]) == (fit["rows"], fit["cols"])
        assert (plan["pan0"], plan["tilt0"]) == (best.pan, best.tilt)
        await survey._task


async def test_a_repeat_is_not_new_and_the_approached_target_was_seen(tmp_path: Path) -> None:
    """Novelty is judged against what the session's earlier stations saw at a point's place
    and scale. The first station has no history; the same view surveyed again (no choice:
    same place, same pointing) finds nothing new, its #1 being the first's #1; walking in on
    that #1, the 60 m station's #1 is the target the 300 m station ranked."""
    config = SurveyConfig(simulate_approach=True)
    async with _engine(tmp_path, config, camera="sim://world?seed=3") as (survey, _, _):
        survey.start(SurveyStart(rows=2, cols=3), "tester")
        await survey._task
        first = survey._result
        assert all(p.novelty is None for p in first.points)
        survey.start(SurveyStart(rows=2, cols=3), "tester")
        await survey._task
        again = survey._result
        assert again.points[0].why.endswith("; #1 at st01-300m"), again.points[0].why
        for p in again.points:  # a point that is no target is neither new nor seen
            assert p.novelty is None if not p.target else p.novelty <= NEW, p
            assert bool(re.search(r"; (#\d at|seen at) st01-300m$", p.why)) == p.target, p.why
        await survey.choose(ChooseTarget(again.station, 1), "tester")
        survey.start(SurveyStart(), "tester")
        await survey._task
        near = survey._result
        assert re.search(r"; #\d at st01-300m$", near.points[0].why), near.points[0].why
        assert near.points[0].novelty == 0.0
        manifest = survey.station.manifest["points"]
        assert [m["novelty"] for m in manifest] == [p.novelty for p in near.points]


async def test_what_no_earlier_station_covered_is_new(tmp_path: Path) -> None:
    """From the same place, a view that does not overlap the first: every target in it is
    new, since nothing earlier looked there."""
    async with _engine(tmp_path, camera="sim://world?seed=3") as (survey, _, _):
        survey.start(SurveyStart(rows=1, cols=1, pan0=-20.0), "tester")
        await survey._task
        survey.start(SurveyStart(rows=1, cols=1, pan0=20.0), "tester")
        await survey._task
        targets = [p for p in survey._result.points if p.target]
        assert targets
        for p in targets:
            assert p.novelty == 1.0 and p.why.endswith("; new since st01-300m"), p.why


async def test_a_station_is_registered_to_the_one_it_was_aimed_from(engine) -> None:
    """Predicted from geometry (the same tripod: directions are unchanged), refined by image
    registration; the residual is small and reported with the correlation reached."""
    survey, _, _ = engine
    survey.cfg = dataclasses.replace(survey.cfg, simulate_approach=True)  # the lens "walks"
    survey.start(SurveyStart(rows=2, cols=3), "tester")
    await survey._task
    first = survey._result
    await survey.choose(ChooseTarget(first.station, 1), "tester")
    survey.start(SurveyStart(rows=1, cols=2), "tester")
    await survey._task
    reg = survey.station.manifest["registration"]
    assert reg["from"] == first.station and reg["prediction"] == "zoom"
    assert reg["overlap"] > 0.5 and reg["correlation"] > 0.5, reg
    assert reg["shift_deg"] < 0.5 and reg["scale"] == pytest.approx(1.0, abs=0.05)
    # Memory: the first station's interest weighed this one's (survey.memory, on by default).
    assert survey.station.manifest["memory"] == {"from": first.station, "weight": survey.cfg.memory}


async def test_the_configured_settings_reach_the_worker_and_the_record(tmp_path: Path) -> None:
    """``survey.settings`` change the profile the worker analyses with: here one point
    instead of three; the station's plan and ``result.json`` say what was used."""
    config = SurveyConfig(settings=("top_n=1", "wide_scale=2"))
    async with _engine(tmp_path, config) as (survey, _, _):
        survey.start(SurveyStart(rows=1, cols=2), "tester")
        await survey._task
        assert len(survey._result.points) == 1
        assert survey.station.manifest["plan"]["settings"] == ["top_n=1", "wide_scale=2"]
        doc = json.loads((survey.station.folder / "analysis" / "result.json").read_text())
        assert (doc["profile"], doc["params"]["top_n"], doc["params"]["wide_scale"]) == (
            "default",
            1,
            2.0,
        )


async def test_a_request_s_settings_replace_the_configured_ones_and_bad_ones_move_nothing(
    tmp_path: Path,
) -> None:
    """2.2: ``survey.start`` may carry settings for its station alone (replacing the
    configured ones; ``()`` means none); a mistyped one is refused by name before the head
    moves or a station is opened."""
    async with _engine(tmp_path, SurveyConfig(settings=("top_n=1",))) as (survey, _, _):
        ptu = survey.rig.ptu
        before = await ptu.position()
        for bad, why in (
            (("blurr=8",), "unknown parameter 'blurr' (did you mean blur?)"),
            (("top_n=-1",), "blur must be > 0; top_n, cooc_sigma, presmooth >= 0"),
            (("uncommon=weird",), "uncommon: cannot read 'weird'"),
        ):
            with pytest.raises(ValueError, match=re.escape(f"settings: {why}")):
                survey.start(SurveyStart(rows=1, cols=2, settings=bad), "tester")
        assert survey.station is None and not survey.running
        assert not any((tmp_path / "archive").rglob("manifest.json"))
        after = await ptu.position()
        assert (after.pan_pos, after.tilt_pos) == (before.pan_pos, before.tilt_pos)

        survey.start(SurveyStart(rows=1, cols=2, settings=("top_n=2",)), "tester")
        await survey._task
        assert len(survey._result.points) == 2
        assert survey.station.manifest["plan"]["settings"] == ["top_n=2"]
        survey.start(SurveyStart(rows=1, cols=2, settings=()), "tester")
        await survey._task
        assert len(survey._result.points) == 3
        assert survey.station.manifest["plan"]["settings"] == []
        doc = json.loads((survey.station.folder / "analysis" / "result.json").read_text())
        assert doc["params"]["top_n"] == 3

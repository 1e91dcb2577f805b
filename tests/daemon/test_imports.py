"""The service loads what it runs: importing the daemon and its CLI does not load the
simulator, its scenes or its world (they come in only for a ``sim://`` camera or the demo),
nor the science core (the vision worker imports it; ``cyborgd analyze`` does)."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from cyborg.daemon.survey import AnalysisJob
from cyborg.daemon.vision.contract import AnalysisResult
from cyborg.daemon.worker import VisionWorker, WorkerError

SIMULATION = (
    "cyborg.daemon.camera.simulated",
    "cyborg.daemon.sim.scene",
    "cyborg.daemon.sim.world",
    "cyborg.daemon.tools.reproduce",
)
SCIENCE = (
    "cyborg.daemon.vision.job",
    "cyborg.daemon.tools.analyze",
    "cyborg.daemon.vision.pipeline",
    "cyborg.daemon.vision.cooccurrence",
    "cyborg.daemon.vision.texture",
    "cyborg.daemon.vision.shadow",
    "cyborg.daemon.vision.interest",
)


def test_importing_the_daemon_does_not_load_the_simulator_or_the_science() -> None:
    probe = (
        "import sys, cyborg.daemon.app, cyborg.daemon.__main__\n"
        f"print(','.join(m for m in {SIMULATION + SCIENCE!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_a_simulated_camera_brings_the_simulator_in() -> None:
    probe = (
        "import sys\nfrom cyborg.daemon.camera import open_camera\n"
        "open_camera('sim://world?seed=1')\n"
        "print('cyborg.daemon.sim.world' in sys.modules "
        "and 'cyborg.daemon.camera.simulated' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"


@dataclass(frozen=True)
class _Liar:
    """A job that promises an analysis and returns a dict (what jobs returned once)."""

    returns: ClassVar[type] = AnalysisResult

    def run(self) -> dict:
        return {"points": []}


async def test_the_worker_runs_the_science_core_for_a_typed_job() -> None:
    """The survey's job is a typed value whose module is light (the science core is imported
    in the worker only) and its result a typed value; anything else is a clear error."""
    async with VisionWorker() as worker:
        folder = tempfile.mkdtemp()
        img = np.full((60, 80, 3), (60, 110, 160), np.uint8)
        img[25:35, 50:60] = (40, 160, 40)
        result = await worker.call(AnalysisJob(folder, img, "paper", "t.png"))
        assert isinstance(result, AnalysisResult) and result.points
        assert result.points[0].rank == 1 and (Path(folder) / "result.json").is_file()
        for wrong in ("cyborg.daemon.vision.job:analyse_into", AnalysisJob):
            with pytest.raises(WorkerError, match="not a worker job"):
                await worker.call(wrong)
        with pytest.raises(WorkerError, match="_Liar returned dict, not AnalysisResult"):
            await worker.call(_Liar())
        assert (await worker.call(AnalysisJob(folder, img, "paper", "t.png"))).points

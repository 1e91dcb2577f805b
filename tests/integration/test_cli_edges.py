"""Scripts at the edges, as real processes against a real daemon: the rig dies mid-survey,
the user presses Ctrl-C, the reader of stdout goes away (``| head``)."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.clients.launch import Daemon
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol.messages import InterestResult, SurveyProgress, SurveyStart, SurveyStatus

pytestmark = pytest.mark.timeout(240)

LINK = ("--rig", "itest", "--name", "script")


async def _surveying(router: str) -> asyncio.subprocess.Process:
    """``cyborg survey --json`` of a 2×3 mosaic (the most the simulated cliff holds),
    returned once its first tile is reported."""
    proc = await asyncio.create_subprocess_exec(
        *(sys.executable, "-m", "cyborg.clients", "survey", "--rows", "2", "--cols", "3", "--json"),
        *(*LINK, "--connect", router, "--timeout", "120"),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    while b"tiles 1/" not in (line := await proc.stderr.readline()):
        assert line, "cyborg survey ended before its first tile"
    return proc


async def _ended(proc: asyncio.subprocess.Process) -> tuple[int, dict, list[str]]:
    """Exit status, the JSON printed, and what stderr said besides progress lines."""
    out, err = await proc.communicate()
    said = [line for line in err.decode().splitlines() if ": tiles " not in line]
    return proc.returncode, json.loads(out), said


async def _to_closed_pipe(*argv: str) -> tuple[int, str]:
    """Run ``argv`` with a stdout nobody reads any more (``| head`` after its line):
    (exit status, stderr)."""
    r, w = os.pipe()
    os.close(r)
    try:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, *argv, stdout=w, stderr=asyncio.subprocess.PIPE
        )
    finally:
        os.close(w)
    _, err = await proc.communicate()
    return proc.returncode, err.decode()


async def test_a_rig_killed_mid_survey_is_reported_unreachable(router: str, daemon: Daemon) -> None:
    """Its liveliness token goes with it: the script exits 3 without waiting out --timeout."""
    proc = await _surveying(router)
    daemon.proc.kill()
    code, report, said = await _ended(proc)
    assert code == 3, said
    assert report == {"ok": False, "error": "rig 'itest' left the bus"}
    assert said == ["cyborg survey: rig 'itest' left the bus"]


async def test_ctrl_c_cancels_the_survey_and_releases_control(
    router: str, daemon: Daemon, client: RigClient, other_client: RigClient
) -> None:
    proc = await _surveying(router)
    proc.send_signal(signal.SIGINT)
    code, report, said = await _ended(proc)
    assert code == 130 and len(said) == 1, said
    assert said[0].startswith("cyborg survey: interrupted; survey cancelled") and not report["ok"]
    assert "control released" in said[0]

    status = await client.command(SurveyStatus())
    assert status.state == "idle" and status.controller == "", status
    # Nobody holds control: another client takes it without taking it over.
    assert await other_client.ensure_control(take_over=False)


async def test_a_closed_pipe_ends_any_command_quietly(
    router: str, daemon: Daemon, client: RigClient
) -> None:
    """Each command run into a pipe whose reader went away (``| head``): exit 141, as
    SIGPIPE would give, and nothing on stderr."""
    await client.wait_alive()
    await client.ensure_control()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    result = await run_station(client, progress, results, SurveyStart(1, 2, 4.0))
    session, station = result.station.split("/")
    link = (*LINK, "--connect", router)
    for command in (
        ("list", "--json"),
        ("list", session),
        ("status",),
        ("export", session, "-o", "-"),
        ("fetch", session, f"{station}/analysis/overlay.png", "-o", "-"),
    ):
        code, err = await _to_closed_pipe("-m", "cyborg.clients", *command, *link)
        assert (code, err) == (141, ""), command


async def test_a_closed_pipe_ends_cyborgd_analyze_quietly(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    image = tmp_path / "noise.png"
    cv2.imwrite(str(image), rng.integers(0, 256, (96, 128, 3), dtype=np.uint8))
    argv = ("-m", "cyborg.daemon", "analyze", "--json", str(image), str(image))
    code, err = await _to_closed_pipe(*argv, "--out", str(tmp_path / "out"))
    assert (code, err) == (141, "")

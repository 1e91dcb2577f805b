"""``cyborg status | goto | survey | fetch | list | choose | halt`` as real processes against a
real daemon: JSON out, exit statuses, control and errors."""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

import pytest

from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import TakeControl

pytestmark = pytest.mark.timeout(180)


async def cyborg(router: str, *args: str, rig: str = "itest") -> tuple[int, dict, str]:
    """Run ``cyborg ARGS --json``; returns (exit status, the JSON it printed, stderr)."""
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "cyborg.clients",
        *args,
        "--json",
        "--rig",
        rig,
        "--connect",
        router,
        "--name",
        "script",
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    out, err = await proc.communicate()
    assert b"Traceback" not in err, err.decode()
    return proc.returncode, json.loads(out), err.decode()


async def test_scripts_drive_a_station_and_fetch_its_products(
    router: str, daemon, other_client: RigClient, tmp_path: Path
) -> None:
    code, status, _ = await cyborg(router, "status")
    assert code == 0 and status["rig"] == "itest" and status["state"] == "idle"
    assert status["protocol"].startswith("2.") and status["ptu"]["link"] == "ready"

    # Nobody holds control: a script takes it to move, and waits for the head to arrive.
    code, moved, _ = await cyborg(router, "goto", "10", "-5", "--wait")
    assert code == 0 and moved["pan"] == pytest.approx(10, abs=0.06)
    assert moved["tilt"] == pytest.approx(-5, abs=0.06)
    code, limit, err = await cyborg(router, "goto", "170", "0")
    assert code == 1 and limit["result"] == "LIMIT" and "limit" in err.lower()
    assert err.count("ptu/goto") == 1 and "PP" not in err, err  # said once, no unit code
    code, bad, err = await cyborg(router, "goto", "1000", "0")
    assert code == 2 and "pan 1000" in bad["error"]

    # Another client took over: scripts do not steal control unless told to.
    await other_client.wait_alive()
    await other_client.command(TakeControl())
    code, held, err = await cyborg(router, "goto", "0", "0")
    assert code == 1 and held["result"] == "REJECTED" and "intruder" in err and "--take" in err
    code, halted, _ = await cyborg(router, "halt")  # halting needs no control
    assert code == 0 and halted["result"] == "OK"

    code, result, err = await cyborg(
        router, "survey", "--rows", "1", "--cols", "2", "--downsample", "4", "--take"
    )
    assert code == 0 and len(result["points"]) == 3, err
    assert "tiles 2/2" in err and "analysis" in err  # progress went to stderr
    assert set(result["points"][0]) >= {"rank", "score", "pan", "tilt", "x", "y", "why"}
    session, station = result["station"].split("/")

    code, listing, _ = await cyborg(router, "list", session)
    assert code == 0 and f"{station}/analysis/overlay.png" in listing["items"]
    out = tmp_path / "overlay.png"
    code, fetched, _ = await cyborg(
        router, "fetch", session, f"{station}/analysis/overlay.png", "-o", str(out)
    )
    archive = Path(daemon.ready["archive"])
    assert (
        code == 0
        and out.read_bytes() == (archive / session / station / "analysis/overlay.png").read_bytes()
    )
    assert fetched["bytes"] == out.stat().st_size and fetched["path"] == str(out)
    code, missing, _ = await cyborg(router, "fetch", session, "nope.png")
    assert code == 1 and missing["result"] == "REJECTED" and "nope.png" in missing["error"]

    code, chose, _ = await cyborg(router, "choose", result["station"], "2")
    assert code == 0 and "60 m" in chose["detail"]

    # A parameter tried for one station (2.2): checked by the rig before the head moves.
    code, refused, err = await cyborg(
        router, "survey", "--rows", "1", "--cols", "2", "--set", "blurr=8"
    )
    assert code == 1 and refused["result"] == "REJECTED" and "did you mean blur?" in err
    assert err.count("survey/start") == 1, err  # the verb said once
    code, one, err = await cyborg(
        router, "survey", "--rows", "1", "--cols", "2", "--downsample", "4", "--set", "top_n=1"
    )
    assert code == 0 and len(one["points"]) == 1, err
    session, station = one["station"].split("/")
    plan = json.loads((archive / session / station / "manifest.json").read_text())["plan"]
    assert plan["settings"] == ["top_n=1"]


async def test_an_absent_rig_is_reported_as_unreachable(router: str) -> None:
    code, report, err = await cyborg(router, "status", "--wait-rig", "0.5", rig="nobody")
    assert code == 3 and "nobody" in report["error"] and "not on the bus" in err
    code, report, _ = await cyborg("tcp/127.0.0.1:1", "status")
    assert code == 3 and "cannot reach tcp/127.0.0.1:1" in report["error"]
    # --json may also come first, as a user types it.
    first = await asyncio.create_subprocess_exec(
        *(sys.executable, "-m", "cyborg.clients", "--json", "status"),
        *("--connect", "tcp/127.0.0.1:1"),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    out, _ = await first.communicate()
    assert first.returncode == 3 and "cannot reach" in json.loads(out)["error"]


async def test_a_malformed_setting_is_a_usage_error_before_any_connection() -> None:
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        *("-m", "cyborg.clients", "survey", "--set", "blur", "--connect", "tcp/127.0.0.1:1"),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    _, err = await proc.communicate()
    assert proc.returncode == 2 and "setting 'blur' is not NAME=VALUE" in err.decode()


async def test_call_sends_any_command_by_its_verb(router: str, daemon) -> None:
    """``cyborg call`` derives from the protocol's registry: every verb, typed replies, the
    request class's own checks, control taken for motion."""
    code, hello, _ = await cyborg(router, "call", "hello", '{"major": 2, "minor": 0}')
    assert code == 0 and hello["kind"] == "hello" and hello["rig"] == "itest"
    code, moved, _ = await cyborg(router, "call", "ptu/goto", '{"pan": 3, "tilt": -1}')
    assert code == 0 and moved["result"] == "OK"
    code, status, _ = await cyborg(router, "call", "survey/status")
    assert code == 0 and status["kind"] == "status" and status["controller"] == "script"
    code, bad, _ = await cyborg(router, "call", "ptu/goto", '{"pan": "ten", "tilt": 0}')
    assert code == 2 and "expected a number" in bad["error"]
    code, bad, _ = await cyborg(router, "call", "ptu/goto", "[1, 2]")
    assert code == 2 and "JSON object" in bad["error"]

"""`make demo`'s program: a daemon, an emulated PTU on a pty, three stations, exit 0."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]


@pytest.mark.timeout(180)
def test_cyborg_demo_runs_three_stations(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    proc = subprocess.run(
        [sys.executable, "-m", "cyborg.clients", "demo", "--out", str(out), "--time-scale", "8"],
        capture_output=True,
        text=True,
        timeout=170,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert "exit status 0" in proc.stdout
    # The world with detail at every range, not the cartoon cliff's magnified pixels.
    assert 'url = "sim://world?' in (out / "cyborgd.toml").read_text()
    manifests = sorted((out / "archive").glob("*/*/manifest.json"))
    assert [m.parent.name for m in manifests] == ["st01-300m", "st02-60m", "st03-10m"]
    # Each choice announces the next station's mosaic; the next station shoots that one.
    announced = re.findall(r"next station at \d+ m .*: a (\d+)×(\d+) mosaic", proc.stdout)
    shot = [json.loads(m.read_text())["plan"] for m in manifests[1:]]
    assert announced == [(str(p["rows"]), str(p["cols"])) for p in shot], proc.stdout
    for m in manifests:
        doc = json.loads(m.read_text())
        assert doc["status"] == "complete" and doc["choice"]["rank"] == 1
        assert (m.parent / "analysis" / "overlay.png").is_file()
        assert str(m.parent / "analysis" / "overlay.png") in proc.stdout
    (log,) = (out / "archive").glob("*/session.mcap")  # one session: the whole approach
    assert f"session log {log}" in proc.stdout
    assert f"report      {log.parent / 'report.html'}" in proc.stdout  # every product, and where
    assert (log.parent / "report.html").is_file()


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="no systemd-analyze here")
def test_systemd_unit_verifies(tmp_path: Path) -> None:
    unit = (ROOT / "systemd" / "cyborgd.service").read_text()
    # The unit names the wearable's install path; point it at this interpreter to verify.
    unit = unit.replace("/opt/cyborg/.venv/bin/cyborgd", sys.executable + " -m daemon")
    path = tmp_path / "cyborgd.service"
    path.write_text(unit)
    proc = subprocess.run(
        ["systemd-analyze", "verify", "--man=no", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0 and proc.stderr.strip() == "", proc.stderr

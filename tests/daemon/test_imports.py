"""The service loads what it runs: importing the daemon and its CLI does not load the
simulator, its scenes or its world (they come in only for a ``sim://`` camera or the demo)."""

from __future__ import annotations

import subprocess
import sys

SIMULATION = ("daemon.camera.simulated", "daemon.scene", "daemon.world", "daemon.demo")


def test_importing_the_daemon_does_not_load_the_simulator() -> None:
    probe = (
        "import sys, daemon.app, daemon.__main__\n"
        f"print(','.join(m for m in {SIMULATION!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_a_simulated_camera_brings_the_simulator_in() -> None:
    probe = (
        "import sys\nfrom daemon.camera import open_camera\n"
        "open_camera('sim://world?seed=1')\n"
        "print('daemon.world' in sys.modules and 'daemon.camera.simulated' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"

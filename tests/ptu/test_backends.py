"""The PTU backend table: every URL the rig took before builds the same backend, each one
imported only when a URL asks for it; and the protocol's bound on a reported step holds
for every emulated model."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

from cyborg.daemon.ptu import BACKENDS, PanTiltUnit, open_ptu
from cyborg.daemon.ptu.models import MODELS
from cyborg.protocol.messages import PtuState


@pytest.mark.parametrize(
    ("url", "kind", "port", "baud"),
    [
        ("/dev/ttyUSB0", "SerialPtu", "/dev/ttyUSB0", 9600),
        ("serial:///dev/ptu?baud=19200", "SerialPtu", "/dev/ptu", 19200),
        ("tcp://10.0.0.7:4000", "SerialPtu", "socket://10.0.0.7:4000", 9600),
        ("socket://h:1?baud=4800", "SerialPtu", "socket://h:1?baud=4800", 4800),
        ("rfc2217://ts:7001", "SerialPtu", "rfc2217://ts:7001", 9600),
    ],
)
def test_serial_urls(url: str, kind: str, port: str, baud: int) -> None:
    ptu = open_ptu(url)
    assert (type(ptu).__name__, ptu.port, ptu.baudrate) == (kind, port, baud)


def test_emulated_urls() -> None:
    emu = open_ptu("emu://?model=46-70&time_scale=3")
    assert type(emu).__name__ == "EmulatedPtu"
    assert (emu.emulator.model.name, emu.emulator.time_scale) == ("46-70", 3.0)
    pty = open_ptu("pty://?fault=drop:PP:2&banner=1&baud=0")
    assert type(pty).__name__ == "PtyPtu"
    assert len(pty.server.faults) == 1 and pty.server.banner and pty.server.baud == 0


@pytest.mark.parametrize(
    ("url", "why"),
    [
        ("serial://", "no serial port"),
        ("tcp://host", "no host:port"),
        ("acme://1", "unknown PTU URL scheme 'acme'"),
        ("emu://?model=D99", "unknown PTU model 'D99'"),
    ],
)
def test_bad_urls(url: str, why: str) -> None:
    with pytest.raises(ValueError, match=why):
        open_ptu(url)


def test_every_row_names_a_backend_with_from_url() -> None:
    for scheme, row in BACKENDS.items():
        module, _, name = row.partition(":")
        backend = getattr(importlib.import_module(module, "cyborg.daemon.ptu"), name)
        assert issubclass(backend, PanTiltUnit) and callable(backend.from_url), scheme


def test_a_real_unit_never_loads_the_emulator() -> None:
    code = (
        "import sys; from cyborg.daemon.ptu import open_ptu; open_ptu('/dev/ttyUSB0'); "
        "print(any(m.startswith('cyborg.daemon.ptu.emul') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_every_model_reports_within_the_protocols_step() -> None:
    for model in MODELS.values():
        step = max(model.pan_resolution, model.tilt_resolution) / 3600.0
        assert step < PtuState.MAX_STEP, model.name

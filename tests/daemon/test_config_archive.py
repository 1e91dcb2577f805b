"""Config parsing, the archive's retrieval rules and crash recovery, sd_notify, control."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cyborg.daemon.__main__ import SIM_CAMERA, SIM_PTU, _simulated
from cyborg.daemon.archive import Archive, ArchiveError
from cyborg.daemon.config import ConfigError, load
from cyborg.daemon.rig import Control
from cyborg.daemon.router import load_router
from cyborg.daemon.sdnotify import Notifier


def _toml(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "c.toml"
    path.write_text(text)
    return path


def test_config_file_and_overrides(tmp_path: Path) -> None:
    path = _toml(
        tmp_path,
        """
rig = "field-1"
ptu = "serial:///dev/ptu"
[camera]
url = "v4l2://0"
hfov = 24
[zenoh]
mode = "peer"
listen = ["tcp/127.0.0.1:7447"]
[survey]
rows = 3
cols = 4
approach = [300, 60, 10]
""",
    )
    cfg = load(path, ptu="emu://")
    assert (cfg.rig, cfg.ptu, cfg.camera.hfov, cfg.survey.rows) == ("field-1", "emu://", 24.0, 3)
    assert cfg.zenoh.listen == ("tcp/127.0.0.1:7447",) and cfg.survey.approach == (300, 60, 10)
    assert cfg.keys.frame == "cyborg/field-1/cam/frame"
    shipped = Path(__file__).parents[2] / "systemd" / "cyborgd.toml"
    assert load(shipped).ptu == "serial:///dev/ptu"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("rgi = 'typo'", "unknown key(s) in"),
        ("[camera]\nulr = 'x'", "unknown key(s) in [camera]: ulr"),
        ("[survey]\nrows = 'two'", "survey.rows: expected an integer"),
        ("[survey]\nrows = 40", "survey.rows 1..16"),
        ("[survey]\nprofile = 'fancy'", "survey.profile must be one of"),
        ("[survey]\napproach = []", "positive distances"),
        ("[survey]\nmemory = 2", "survey.memory must be in [0, 1]"),
        ("[survey]\nsettings = ['blurr=3']", "survey.settings: unknown parameter 'blurr'"),
        ("[survey]\nsettings = ['uncommon=rarest']", "cannot read 'rarest' as rank | spread"),
        ("[survey]\nsettings = [3]", 'survey.settings must list "NAME=VALUE" texts'),
        ("[survey]\nsettings = 'top_n=1'", "survey.settings: expected a list"),
        ("[camera]\nhfov = 0", "camera.hfov"),
        ("[zenoh]\nmode = 'client'", "client mode needs"),
        ("[zenoh]\nlisten = 'tcp/x'", "zenoh.listen: expected a list"),
        ("[zenoh]\nlisten = ['7447']", "want proto/address"),
        ("rig = 'a/b'", "rig name"),
        ("camera = 3", "[camera] must be a table"),
        ("not toml [", "not valid TOML"),
        ("[zenoh]\nlisten = ['tcp/0.0.0.0:7447']", "clear text beyond this machine"),
        ("[zenoh]\nlisten = ['tls/0.0.0.0:7447']", "need tls_ca"),
        ("[zenoh]\nusers = 'nope.toml'", "zenoh.users"),
        ("[zenoh]\naccess = {}", "unknown key(s) in [zenoh]: access"),
        ("[record]\nframes = 100", "record.frames must be 0..30"),
        ("[record]\nenable = true", "unknown key(s) in [record]: enable"),
    ],
)
def test_config_errors_name_the_key(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=None) as info:
        load(_toml(tmp_path, text))
    assert message in str(info.value)


def test_the_shipped_config_is_secure_by_default() -> None:
    """Nothing in clear text beyond the machine, TLS for remote peers, an access list, and
    a unix socket for the keypad."""
    cfg = load(Path(__file__).parents[2] / "systemd" / "cyborgd.toml")
    z = cfg.zenoh
    assert not z.exposed() and not z.insecure and z.reachable() == ("tls/0.0.0.0:7447",)
    assert z.unix_sockets() == ("/run/cyborgd/bus.sock",) and z.mtls
    assert z.access is not None and z.access["default_permission"] == "deny"
    assert z.tls_ca.endswith("systemd/tls/ca.crt")  # relative to the config file


def test_clear_text_beyond_loopback_only_when_said(tmp_path: Path) -> None:
    text = "[zenoh]\nlisten = ['tcp/0.0.0.0:7447']\ninsecure = true"
    assert load(_toml(tmp_path, text)).zenoh.exposed() == ("tcp/0.0.0.0:7447",)
    local = "[zenoh]\nlisten = ['tcp/127.0.0.1:7447', 'tcp/[::1]:7447', 'unixsock-stream//x']"
    assert load(_toml(tmp_path, local)).zenoh.exposed() == ()


def test_missing_config_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load(tmp_path / "nope.toml")


def test_archive_serves_products_and_nothing_else(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a", "r")
    archive.open()
    session = archive.new_session()
    station = archive.new_station(session, 1, 300.0)
    station.write("notes.txt", b"layered sandstone")
    (station.folder / ".notes.txt.tmp123").write_bytes(b"half")
    (tmp_path / "a" / "secret.txt").write_bytes(b"no")
    assert archive.sessions() == [session]
    assert archive.products(session) == ["st01-300m/manifest.json", "st01-300m/notes.txt"]
    assert archive.read(session, "st01-300m/notes.txt", 1000) == b"layered sandstone"
    for bad_session, bad_product in [
        (session, "../secret.txt"),
        (session, "st01-300m/.notes.txt.tmp123"),
        (session, "/etc/passwd"),
        (session, "st01-300m"),
        ("..", "secret.txt"),
        ("", "x"),
        ("nope", "x"),
    ]:
        with pytest.raises(ArchiveError):
            archive.read(bad_session, bad_product, 1000)
    with pytest.raises(ArchiveError, match="over the 5-byte"):
        archive.read(session, "st01-300m/notes.txt", 5)


def test_tiles_and_chips_are_listed_with_their_poses(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    archive.open()
    station = archive.new_station(archive.new_session(), 1, 300.0)
    image = np.full((24, 32, 3), 90, np.uint8)
    assert station.add_tile(1, 2, image, (-15.0, 4.5), 10.0) == "tiles/r1c2.png"
    assert station.add_chip(3, image, (2.0, -1.0), 11.0) == "chips/chip3.png"
    m = json.loads((station.folder / "manifest.json").read_text())
    assert m["tiles"] == [
        {"file": "tiles/r1c2.png", "row": 1, "col": 2, "pan": -15.0, "tilt": 4.5, "t": 10.0}
    ]
    assert m["chips"] == [
        {"file": "chips/chip3.png", "rank": 3, "pan": 2.0, "tilt": -1.0, "t": 11.0}
    ]
    for rel in ("tiles/r1c2.png", "chips/chip3.png"):
        assert m["files"][rel] == (station.folder / rel).stat().st_size > 0


def test_archive_recovers_interrupted_stations(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    archive.open()
    session = archive.new_session()
    archive.new_station(session, 1, 300.0)  # left in progress, as after a SIGKILL
    done = archive.new_station(session, 2, 60.0)
    done.finish("complete")
    (done.folder / ".analysis.partial").mkdir()
    assert Archive(tmp_path / "a").open() == [f"{session}/st01-300m"]
    assert not (done.folder / ".analysis.partial").exists()  # left by a crash: gone
    m = json.loads((tmp_path / "a" / session / "st01-300m" / "manifest.json").read_text())
    assert m["status"] == "incomplete" and "stopped" in m["reason"]
    assert Archive(tmp_path / "a").open() == []


def test_sd_notify_over_a_real_socket(tmp_path: Path) -> None:
    path = str(tmp_path / "notify")
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as server:
        server.bind(path)
        env = {"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "4000000", "WATCHDOG_PID": str(os.getpid())}
        notifier = Notifier(env)
        assert notifier.enabled and notifier.watchdog_interval == 2.0
        notifier.notify("READY=1")
        assert server.recv(100) == b"READY=1"
    assert Notifier({}).watchdog_interval is None and not Notifier({}).enabled
    Notifier({}).notify("READY=1")  # outside systemd: nothing, no error
    assert Notifier({"WATCHDOG_USEC": "5", "WATCHDOG_PID": "1"}).watchdog_interval is None


def test_control_is_explicit() -> None:
    control = Control()
    assert not control.allows("a") and not control.allows("")
    assert control.take("a") == ""
    assert control.allows("a") and not control.allows("b")
    assert control.take("b") == "a"
    assert not control.release("a") and control.release("b") and control.holder == ""


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('listen = ["tls/0.0.0.0:7448"]\nusers = "users.toml"', "rig is required"),
        ('rig = "r"\nlisten = ["tcp/0.0.0.0:7448"]\nusers = "users.toml"', "clear text"),
        ('rig = "r"\nlisten = ["tls/0.0.0.0:7448"]\nusers = "users.toml"', "tls_ca"),
        ('rig = "r"\nlisten = []\nusers = "nope.toml"', "nope.toml"),
        ('rig = "r"\nlisten = []\nusers = "users.toml"\nacl = 1', "unknown key(s): acl"),
    ],
)
def test_router_config_errors_say_what(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "users.toml").write_text('[[user]]\nname = "alice"\nrole = "operator"\n')
    path = tmp_path / "router.toml"
    path.write_text(text.replace('"users.toml"', f'"{tmp_path / "users.toml"}"'))
    with pytest.raises(ValueError, match=None) as info:
        load_router(path)
    assert message in str(info.value)


def test_archive_files_are_readable_by_the_group(tmp_path: Path) -> None:
    """Under systemd (UMask=0027) results are 0640: the geologist in group cyborg reads them."""
    code = (
        "import os, sys; os.umask(0o027); from pathlib import Path;"
        "from cyborg.daemon.vision.imageio import write_atomic;"
        "write_atomic(Path(sys.argv[1]), b'x')"
    )
    target = tmp_path / "a" / "result.json"
    subprocess.run([sys.executable, "-c", code, str(target)], check=True)
    assert target.stat().st_mode & 0o777 == 0o640


def test_sim_keeps_what_the_config_file_chose(tmp_path: Path) -> None:
    """``cyborgd run --sim --config site.toml``: the simulation fills in only what neither a
    flag nor the file chose; the file's archive, PTU and camera are kept."""
    path = _toml(
        tmp_path,
        f"""
archive = "{tmp_path / "site-archive"}"
ptu = "pty://?model=D46-70"
[camera]
url = "sim://outcrop?seed=9&hfov=20"
""",
    )
    kept = _simulated(load(path))
    assert kept.ptu == "pty://?model=D46-70" and kept.camera.url.endswith("seed=9&hfov=20")
    assert kept.archive == tmp_path / "site-archive" and kept.survey.simulate_approach
    bare = tmp_path / "bare"
    bare.mkdir()
    filled = _simulated(load(_toml(bare, "[survey]\nrows = 1")))
    assert (filled.ptu, filled.camera.url, filled.archive) == (SIM_PTU, SIM_CAMERA, Path("out/rig"))
    proc = subprocess.Popen(
        [
            *(sys.executable, "-m", "cyborg.daemon", "run", "--sim", "--config", str(path)),
            *("--listen", "tcp/127.0.0.1:0", "--ptu", "pty://?model=D46-17&time_scale=50"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        ready = json.loads(proc.stdout.readline())
        assert ready["archive"] == str((tmp_path / "site-archive").resolve())
    finally:
        proc.terminate()
        proc.wait(30)

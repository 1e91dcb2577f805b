"""One rule for every side and both directions: clear text beyond loopback, dialled or
listened on, is refused unless said in so many words; a TLS listener that asks nobody's
name is refused; a rig open to every local user says so once at start."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cyborg.clients.launch import free_port, launch
from cyborg.daemon.config import ConfigError, load
from cyborg.daemon.router import load_router
from cyborg.protocol.transport import Transport

pytestmark = pytest.mark.timeout(120)

ROUTER = "tcp/router.field:7447"
TLS = "tls_ca = 'ca.crt'\ntls_cert = 'rig.crt'\ntls_key = 'rig.key'\n"
"""[zenoh] TLS files; only their names are checked when a config loads."""


def _config(tmp_path: Path, zenoh: str) -> Path:
    path = tmp_path / "cyborgd.toml"
    path.write_text(f"[zenoh]\n{zenoh}\n")
    return path


@pytest.mark.parametrize(
    "zenoh",
    [
        f"mode = 'client'\nconnect = ['{ROUTER}']",
        "connect = ['tcp/192.0.2.7:7447']",
        "listen = ['tcp/127.0.0.1:7447']\nconnect = ['ws/10.0.0.2:8000']",
    ],
)
def test_dialling_clear_text_beyond_loopback_is_refused_like_listening(
    tmp_path: Path, zenoh: str
) -> None:
    with pytest.raises(ConfigError, match="clear text beyond this machine"):
        load(_config(tmp_path, zenoh))
    said = load(_config(tmp_path, zenoh + "\ninsecure = true")).zenoh
    assert said.exposed() and said.insecure


def test_loopback_and_unix_sockets_are_dialled_without_a_word(tmp_path: Path) -> None:
    local = "connect = ['tcp/127.0.0.1:7447', 'tcp/localhost:7448', 'unixsock-stream//x']"
    assert load(_config(tmp_path, local)).zenoh.exposed() == ()


@pytest.mark.parametrize(
    ("zenoh", "refused"),
    [
        (f"listen = ['tls/0.0.0.0:7447']\nmtls = false\n{TLS}", True),
        (f"listen = ['tls/0.0.0.0:7447']\nmtls = false\nusers = 'users.toml'\n{TLS}", True),
        (f"listen = ['tls/0.0.0.0:7447']\nmtls = false\npasswords = 'pw'\n{TLS}", False),
        (f"listen = ['tls/0.0.0.0:7447']\n{TLS}", False),
        (f"listen = ['tls/127.0.0.1:7447']\nmtls = false\n{TLS}", False),
    ],
)
def test_a_tls_listener_beyond_loopback_must_ask_a_name(
    tmp_path: Path, zenoh: str, refused: bool
) -> None:
    (tmp_path / "users.toml").write_text('[[user]]\nname = "alice"\nrole = "operator"\n')
    if refused:
        with pytest.raises(ConfigError, match="mtls = false without passwords"):
            load(_config(tmp_path, zenoh))
    else:
        load(_config(tmp_path, zenoh))


def test_the_router_asks_a_name_too(tmp_path: Path) -> None:
    (tmp_path / "users.toml").write_text('[[user]]\nname = "alice"\nrole = "operator"\n')
    path = tmp_path / "router.toml"
    path.write_text(f'rig = "r"\nlisten = ["tls/0.0.0.0:7448"]\nusers = "users.toml"\n{TLS}')
    load_router(path)
    path.write_text(path.read_text() + "mtls = false\n")
    with pytest.raises(ValueError, match="mtls = false without passwords"):
        load_router(path)


def test_the_daemon_and_clients_refuse_to_dial_clear_text_beyond_loopback() -> None:
    """As processes: ``cyborgd run`` and ``cyborg status`` stop at once with the reason."""
    runs = [
        ["cyborg.daemon", "run", "--ptu", "emu://", "--mode", "client", "--connect", ROUTER],
        ["cyborg.clients", "status", "--connect", ROUTER],
    ]
    for argv in runs:
        done = subprocess.run(
            [sys.executable, "-m", *argv], check=False, capture_output=True, timeout=60
        )
        assert done.returncode == 2, (argv, done.stderr)
        assert b"would carry the bus in clear text beyond this machine" in done.stderr
    assert Transport("client", connect=(ROUTER,), insecure=True).exposed() == (ROUTER,)


async def test_a_rig_open_to_every_local_user_says_so_once(tmp_path: Path) -> None:
    """``cyborgd run`` on loopback TCP without a users file (as ``--sim`` and ``make rig``)."""
    log = tmp_path / "cyborgd.log"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    args = ["--ptu", "emu://", "--camera", "sim://outcrop?seed=3&hfov=30"]
    args += ["--archive", str(tmp_path / "archive"), "--listen", endpoint]
    async with launch(args, log):
        pass
    notices = [line for line in log.read_text().splitlines() if "any user of this machine" in line]
    assert len(notices) == 1 and endpoint in notices[0]


def test_an_endpoint_that_is_no_zenoh_link_is_a_usage_error() -> None:
    """``--connect http://rig:7447`` is a typo (exit 2), not an unreachable rig (exit 3)."""
    with pytest.raises(ValueError, match="proto one of tcp, udp, tls"):
        Transport("client", connect=("http://127.0.0.1:7447",))
    done = subprocess.run(
        [sys.executable, "-m", "cyborg.clients", "status", "--connect", "http://127.0.0.1:7447"],
        check=False,
        capture_output=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stderr
    assert b"want proto/address" in done.stderr and b"Traceback" not in done.stderr

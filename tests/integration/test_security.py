"""Secure tele-operation end to end: real ``cyborgd`` and ``cyborgd router`` processes,
mutual TLS with certificates made by ``systemd/cyborg-certs.sh`` (the documented recipe),
the access list generated from a users file, clients as real zenoh sessions on loopback.

Every role is tried allowed and denied: an operator's certificate, a viewer's, a valid
certificate of an unknown name, no certificate, another CA's certificate, clear TCP to
the TLS port; impersonation; a stranger's telemetry.
"""

from __future__ import annotations

import asyncio
import contextlib
import shutil
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import pytest
import zenoh

from cyborg.clients.launch import Daemon, free_port, make_certificates, simulated_config, spawn
from cyborg.clients.rigclient import RigClient, RigUnavailableError
from cyborg.protocol.envelope import encode
from cyborg.protocol.link import open_session
from cyborg.protocol.messages import Hello, PtuGoto, PtuState, SurveyStatus, TakeControl
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl")

RIG = "itest"
USERS = '[[user]]\nname = "alice"\nrole = "operator"\n[[user]]\nname = "bob"\nrole = "viewer"\n'


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A CA, the rig's and the router's host certificates, alice, bob and eve (valid, but
    in no users file); and a foreign CA with its own 'alice'."""
    pki = make_certificates(
        tmp_path_factory.mktemp("pki"), (RIG, "router"), ("alice", "bob", "eve")
    )
    (pki / "users.toml").write_text(USERS)
    return pki


def _tls(pki: Path, name: str, ca: Path | None = None) -> dict[str, str]:
    return {
        "tls_ca": str(ca or pki / "ca.crt"),
        "tls_cert": str(pki / f"{name}.crt"),
        "tls_key": str(pki / f"{name}.key"),
    }


@contextlib.contextmanager
def _client(endpoint: str, name: str, mode: str = "client", **tls: str) -> Iterator[RigClient]:
    with RigClient.open(Transport(mode, connect=(endpoint,), **tls), RIG, name) as c:
        yield c


async def _fakes_never_reach(forger: RigClient, viewer: RigClient) -> None:
    """``forger`` puts a made-up PTU state on the rig's key, ten times over: the viewer
    keeps receiving the rig's own states, never the fake."""
    states = viewer.subscribe(viewer.keys.ptu_state, PtuState)
    fake = encode(PtuState.KIND, PtuState(150.0, -40.0, False).to_body(), src=RIG)
    seen: list[PtuState] = []
    async with asyncio.timeout(10):
        while len(seen) < 10:
            forger.session.put(forger.keys.ptu_state, fake)
            seen.append(await states.get())
    assert all(s.pan != 150.0 for s in seen)


@pytest.fixture(params=["direct", "router"])
async def rig(request, pki: Path, tmp_path: Path) -> AsyncIterator[str]:
    """The rig behind TLS: listening itself with the access list (``direct``), or dialling
    a ``cyborgd router`` that holds it (``router``). Yields the endpoint clients dial."""
    port = free_port()
    endpoint = f"tls/127.0.0.1:{port}"
    started: list[Daemon] = []
    try:
        if request.param == "direct":
            zenoh_keys = {"listen": [endpoint], **_tls(pki, RIG), "users": str(pki / "users.toml")}
            config = simulated_config(RIG, tmp_path / "archive", time_scale=8, zenoh=zenoh_keys)
        else:
            router = tmp_path / "router.toml"
            router.write_text(
                f'rig = "{RIG}"\nlisten = ["{endpoint}"]\nusers = "{pki / "users.toml"}"\n'
                + "".join(f'{k} = "{v}"\n' for k, v in _tls(pki, "router").items())
            )
            log = tmp_path / "router.log"
            started.append(await spawn(["--config", str(router)], log, command="router"))
            zenoh_keys = {"mode": "client", "connect": [endpoint], **_tls(pki, RIG)}
            config = simulated_config(RIG, tmp_path / "archive", time_scale=8, zenoh=zenoh_keys)
        path = tmp_path / "cyborgd.toml"
        path.write_text(config)
        started.append(await spawn(["--config", str(path)], tmp_path / "cyborgd.log"))
        yield endpoint
    finally:
        for process in reversed(started):
            await process.stop()


async def test_operator_commands_viewer_watches(rig: str, pki: Path) -> None:
    # alice in peer mode, as the console and the keypad run; bob in client mode, as scripts.
    with (
        _client(rig, "alice", "peer", **_tls(pki, "alice")) as alice,
        _client(rig, "bob", **_tls(pki, "bob")) as bob,
    ):
        await alice.wait_alive()
        await bob.wait_alive()
        states = bob.subscribe(bob.keys.ptu_state, PtuState)
        hello = await alice.command(Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR))
        assert hello.rig == RIG
        await alice.command(TakeControl())
        await alice.command(PtuGoto(4.0, -1.0))
        async with asyncio.timeout(20):
            state = await states.get()
            while (state.pan, state.tilt, state.moving) != pytest.approx(
                (4.0, -1.0, False), abs=0.06
            ):
                state = await states.get()
        # The viewer reads status and the archive, and is answered nothing else.
        status = await bob.command(SurveyStatus())
        assert status.controller == "alice"
        for request in (TakeControl(), PtuGoto(0.0, 0.0)):
            with pytest.raises(RigUnavailableError):
                await bob.call(request, timeout=1.5)
        # Nobody speaks for another: alice's query on bob's key goes nowhere.
        with pytest.raises(RigUnavailableError):
            await alice.call_raw("hello", alice.request(Hello(2, 0)), 1.5, client="bob")


async def test_strangers_get_nothing(rig: str, pki: Path) -> None:
    # A valid certificate of a name in no users file: connected, but nothing flows.
    with _client(rig, "eve", **_tls(pki, "eve")) as eve:
        states = eve.subscribe(eve.keys.ptu_state, PtuState)
        with pytest.raises(RigUnavailableError):
            await eve.wait_alive(timeout=2.0)
        with pytest.raises(RigUnavailableError):
            await eve.call(Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR), timeout=1.5)
        assert states.empty()
    # No link at all: no certificate, another CA's 'alice', clear TCP on the TLS port.
    tries = {
        "no certificate": Transport("client", connect=(rig,), tls_ca=str(pki / "ca.crt")),
        "another CA": Transport(
            "client", connect=(rig,), **_tls(pki / "foreign", "alice", pki / "ca.crt")
        ),
        "clear tcp": Transport("client", connect=("tcp/" + rig.split("/", 1)[1],)),
    }
    for what, transport in tries.items():
        with pytest.raises(zenoh.ZError, match="Unable to connect"):
            open_session(transport).close()
        assert what


async def test_only_the_rig_publishes_telemetry(rig: str, pki: Path) -> None:
    """alice (an operator) puts a fake state on the rig's key: bob never sees it, while he
    keeps seeing the rig's own states."""
    with (
        _client(rig, "alice", **_tls(pki, "alice")) as alice,
        _client(rig, "bob", **_tls(pki, "bob")) as bob,
    ):
        await bob.wait_alive()
        await _fakes_never_reach(alice, bob)


async def test_impersonation_in_the_envelope_is_refused(rig: str, pki: Path) -> None:
    """Even an operator's own key cannot carry another name in its envelope."""
    with _client(rig, "alice", **_tls(pki, "alice")) as alice:
        await alice.wait_alive()
        forged = encode(TakeControl.KIND, {}, src="bob", corr="x")
        reply = await alice.call_raw("control/take", forged)
        assert reply.result == "REJECTED" and "speaks only for itself" in reply.detail


async def test_a_refused_handshake_is_explained_in_the_rig_log(pki: Path, tmp_path: Path) -> None:
    """zenoh's own warning for a rejected certificate reaches the daemon's log."""
    endpoint = f"tls/127.0.0.1:{free_port()}"
    keys = {"listen": [endpoint], **_tls(pki, RIG), "users": str(pki / "users.toml")}
    path = tmp_path / "cyborgd.toml"
    path.write_text(simulated_config(RIG, tmp_path / "archive", zenoh=keys))
    log = tmp_path / "cyborgd.log"
    daemon = await spawn(["--config", str(path)], log)
    try:
        foreign = _tls(pki / "foreign", "alice", pki / "ca.crt")  # trusts us; we do not
        with pytest.raises(zenoh.ZError):
            open_session(Transport("client", (), (endpoint,), **foreign))
        async with asyncio.timeout(10):
            while "WARNING zenoh.zenoh_link_tls" not in log.read_text():
                await asyncio.sleep(0.1)
        assert "invalid peer certificate" in log.read_text()
    finally:
        await daemon.stop()


async def test_local_clients_use_the_unix_socket(pki: Path, tmp_path: Path) -> None:
    """On the wearable the keypad dials the rig's unix socket: any name may command there
    (the socket's mode is the credential), nobody there may publish telemetry, and the
    remote side stays TLS with its access list."""
    socket_path = tmp_path / "bus.sock"
    tls_endpoint = f"tls/127.0.0.1:{free_port()}"
    keys = {
        "listen": [f"unixsock-stream/{socket_path}", tls_endpoint],
        **_tls(pki, RIG),
        "users": str(pki / "users.toml"),
    }
    path = tmp_path / "cyborgd.toml"
    path.write_text(simulated_config(RIG, tmp_path / "archive", time_scale=8, zenoh=keys))
    daemon = await spawn(["--config", str(path)], tmp_path / "cyborgd.log")
    try:
        assert socket_path.stat().st_mode & 0o777 == 0o660
        local = f"unixsock-stream/{socket_path}"
        with (
            _client(local, "keypad-field", "peer") as keypad,
            _client(tls_endpoint, "bob", **_tls(pki, "bob")) as bob,
        ):
            await keypad.wait_alive()
            await bob.wait_alive()
            await keypad.command(TakeControl())
            assert (await bob.command(SurveyStatus())).controller == "keypad-field"
            await _fakes_never_reach(keypad, bob)
    finally:
        await daemon.stop()


async def test_password_users_through_the_router(pki: Path, tmp_path: Path) -> None:
    """A user without a certificate logs in with a password over the router's TLS (no
    client certificate asked): the same access list, by username; a wrong password is
    refused at the link."""
    endpoint = f"tls/127.0.0.1:{free_port()}"
    (tmp_path / "passwords").write_text(f"alice:s3cret\nbob:b0b\n{RIG}:r1g\n")
    router = tmp_path / "router.toml"
    router.write_text(
        f'rig = "{RIG}"\nlisten = ["{endpoint}"]\nusers = "{pki / "users.toml"}"\n'
        f'passwords = "{tmp_path / "passwords"}"\nmtls = false\n'
        + "".join(f'{k} = "{v}"\n' for k, v in _tls(pki, "router").items())
    )
    started = [await spawn(["--config", str(router)], tmp_path / "router.log", command="router")]
    try:
        config = tmp_path / "cyborgd.toml"
        # Once the router asks passwords, every peer gives one: the rig too.
        keys = {"mode": "client", "connect": [endpoint], "user": RIG, "password": "r1g"}
        keys |= _tls(pki, RIG)
        config.write_text(simulated_config(RIG, tmp_path / "archive", time_scale=8, zenoh=keys))
        started.append(await spawn(["--config", str(config)], tmp_path / "cyborgd.log"))
        ca = str(pki / "ca.crt")
        with _client(endpoint, "alice", tls_ca=ca, user="alice", password="s3cret") as alice:
            await alice.wait_alive()
            await alice.command(TakeControl())
            assert (await alice.command(SurveyStatus())).controller == "alice"
        wrong = Transport("client", (), (endpoint,), tls_ca=ca, user="alice", password="guess")
        with pytest.raises(zenoh.ZError):
            open_session(wrong).close()
    finally:
        for process in reversed(started):
            await process.stop()

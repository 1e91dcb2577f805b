"""The link: the one module that opens zenoh sessions and hands their callbacks to asyncio;
the rest of ``protocol`` stays pure."""

from __future__ import annotations

import asyncio
import pkgutil
import subprocess
import sys
import threading
from pathlib import Path

import zenoh

import cyborg.protocol
from cyborg.protocol.link import ADMIN_SPACE, SOCKET_MODE, locators, open_session, to_loop
from cyborg.protocol.transport import Transport

ROOT = Path(__file__).parents[2]


def test_the_wire_contract_imports_neither_zenoh_nor_asyncio() -> None:
    """Each module of ``protocol`` but the link, imported alone in a fresh interpreter."""
    names = [m.name for m in pkgutil.iter_modules(cyborg.protocol.__path__) if m.name != "link"]
    assert {"envelope", "keys", "messages", "transport"} <= set(names)
    for name in names:
        probe = (
            f"import sys, cyborg.protocol.{name}\n"
            "print(sorted({'zenoh', 'asyncio'} & {m.split('.')[0] for m in sys.modules}))"
        )
        out = subprocess.run(
            [sys.executable, "-c", probe], capture_output=True, text=True, check=True, cwd=ROOT
        )
        assert out.stdout.strip() == "[]", f"cyborg.protocol.{name} imports {out.stdout}"


def test_one_module_opens_sessions_and_hands_callbacks_to_the_loop() -> None:
    """``zenoh.open(`` and ``call_soon_threadsafe`` are written in the link alone, among the
    packages and the benchmarks."""
    for needle in ("zenoh.open(", "call_soon_threadsafe"):
        found = sorted(
            str(path.relative_to(ROOT))
            for folder in ("daemon", "clients", "protocol", "bench")
            for path in (ROOT / folder).rglob("*.py")
            if needle in path.read_text()
        )
        assert found == ["protocol/link.py"], needle


async def test_a_session_from_the_transport_hands_samples_to_the_loop(tmp_path: Path) -> None:
    """A router on a unix socket (made group-writable) and a kernel-picked port (read back);
    a client's subscriber gets what ``pick`` keeps, on the event loop's thread."""
    socket_path = tmp_path / "bus.sock"
    unix = f"unixsock-stream/{socket_path}"
    router = Transport("router", listen=("tcp/127.0.0.1:0", unix))
    got: asyncio.Queue[tuple[bytes, int]] = asyncio.Queue()

    def pick(sample: zenoh.Sample) -> bytes | None:
        data = sample.payload.to_bytes()
        return None if data == b"dropped" else data

    with open_session(router, ADMIN_SPACE) as rig:
        assert socket_path.stat().st_mode & 0o777 == SOCKET_MODE
        tcp = [ep for ep in locators(rig) if ep.startswith("tcp/")]
        assert tcp and not tcp[0].endswith(":0")
        with open_session(Transport("client", connect=(unix,))) as client:
            sub = client.declare_subscriber(
                "link/test",
                to_loop(lambda data: got.put_nowait((data, threading.get_ident())), pick),
            )
            publisher = rig.declare_publisher("link/test")
            async with asyncio.timeout(30):
                while not publisher.matching_status.matching:
                    await asyncio.sleep(0.05)
                publisher.put(b"dropped")
                publisher.put(b"kept")
                data, thread = await got.get()
            assert (data, thread) == (b"kept", threading.get_ident())
            publisher.undeclare()
            sub.undeclare()


def test_a_taken_port_and_nobody_listening_are_said_without_rust_sources() -> None:
    """A port another rig holds, an endpoint nobody listens on: zenoh's own errors, with no
    ``…/tcp.rs:61`` for the person reading them."""
    router = open_session(Transport("router", listen=("tcp/127.0.0.1:0",)), ADMIN_SPACE)
    try:
        taken = locators(router)[0]
        for transport in (
            Transport("router", listen=(taken,)),
            Transport("client", connect=(taken.rsplit(":", 1)[0] + ":1",)),
        ):
            try:
                open_session(transport).close()
            except zenoh.ZError as exc:
                assert ".rs:" not in str(exc) and "/root/" not in str(exc), exc
            else:
                raise AssertionError(f"{transport} opened")
    finally:
        router.close()

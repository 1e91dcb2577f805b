"""Security benchmark: does anything hostile get through, and what does TLS cost?

A real ``cyborgd`` (PTU emulator on a pty, simulated camera, live view at 25 fps) listens
on mutual TLS with the access list generated from a users file (alice operator, bob
viewer); certificates come from the documented recipe. Then:

* **hostile queries**: ``--queries`` malformed, mistyped, out-of-range, forged,
  other-version and control-less requests over every command key that changes something
  (read-only ones are the viewer's, ``Request.READ_ONLY``), sent by the operator
  herself (the most privileged stranger there is), concurrently, bounded in time;
* **strangers**: no certificate, another CA's certificate, clear TCP on the TLS port, a
  valid certificate of an unknown name, the viewer sending what its role forbids, the
  operator sending on the viewer's key, and fake telemetry put by the operator;
* **the console**: cross-origin and DNS-rebinding requests, token-less calls, text/plain
  posts and a foreign-origin WebSocket against a real ``cyborg operator``.

Each attempt is *refused* (an error reply, an ERROR/REJECTED/LIMIT ack, no answer, a
refused link, a 4xx) or *executed* (an OK answer, a head that moved, a fake state seen).
``crashed`` counts daemon deaths. The daemon's resident memory is read before and after.
Finally frame latency at 25 fps over TLS with the access list versus clear TCP (same
daemon build, same machine, measured in the same run).

Usage: ``python -m bench.security [--queries 10000] [--seconds 5] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import random
import sys
import tempfile
import time
from collections import Counter
from dataclasses import fields
from pathlib import Path

import aiohttp
import msgpack
import zenoh

from bench.stats import latency
from cyborg.clients.launch import (
    Daemon,
    free_port,
    make_certificates,
    operator,
    simulated_config,
    spawn,
)
from cyborg.clients.rigclient import RigClient, RigError, RigUnavailableError
from cyborg.protocol.envelope import decode, encode
from cyborg.protocol.keys import COMMANDS
from cyborg.protocol.link import on_thread, open_session
from cyborg.protocol.messages import REQUESTS, Ack, PtuState, TakeControl
from cyborg.protocol.transport import Transport

RIG = "secbench"
USERS = '[[user]]\nname = "alice"\nrole = "operator"\n[[user]]\nname = "bob"\nrole = "viewer"\n'
FPS = 25


def _tls(pki: Path, name: str, ca: Path | None = None) -> dict[str, str]:
    return {
        "tls_ca": str(ca or pki / "ca.crt"),
        "tls_cert": str(pki / f"{name}.crt"),
        "tls_key": str(pki / f"{name}.key"),
    }


def _rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def _hostile(rng: random.Random, verb: str) -> bytes:
    """One request to ``cmd/alice/<verb>`` that must be refused: each has a defect."""
    request = REQUESTS[verb]
    kind, names = request.KIND, [f.name for f in fields(request)]
    defect = rng.randrange(8)
    if defect in (5, 6) and not names:
        defect = 3  # nothing to mistype: forge the sender instead
    if defect == 0:
        return rng.randbytes(rng.randrange(0, 64))
    if defect == 1:
        return msgpack.packb([1, 2, {"k": kind}])
    if defect == 2:  # a 1.x envelope
        return msgpack.packb({"v": 1, "k": kind, "src": "alice", "body": {}})
    if defect == 3:  # someone else's name in the envelope
        return encode(kind, {}, src=rng.choice(["bob", "cyborgd", "", "alice "]))
    if defect == 4:  # the wrong kind for the key, up to 60 kB of it
        return encode("x" * rng.randrange(1, 60_000), {}, src="alice")
    if defect == 5:  # every field of the wrong type
        return encode(kind, {n: [rng.random()] for n in names}, src="alice")
    if defect == 6:  # every field out of range, not finite or an escape
        bad = [float("nan"), 1e300, -(10**12), "../../etc/passwd", "x" * 5000]
        return encode(kind, {n: rng.choice(bad) for n in names}, src="alice")
    return encode(kind, {}, src="alice" + "x" * rng.randrange(60, 5000))


async def _hostile_queries(alice: RigClient, n: int, seconds: float) -> Counter:
    """``n`` hostile requests over every verb that is not read-only, 32 at a time, within
    ``seconds``."""
    rng = random.Random(7)
    verbs = [v for v in COMMANDS if not REQUESTS[v].READ_ONLY]
    out: Counter = Counter(tried=0, refused=0, executed=0)
    deadline = time.monotonic() + seconds
    sem = asyncio.Semaphore(32)

    async def one(verb: str, payload: bytes) -> None:
        async with sem:
            if time.monotonic() > deadline:
                out["not sent (time bound)"] += 1
                return
            try:
                reply = await alice.call_raw(verb, payload, timeout=5.0)
            except RigUnavailableError:
                out["refused"] += 1
                out["answer: none"] += 1
                return
            except RigError:
                out["refused"] += 1
                out["answer: plain-text error"] += 1  # another protocol version
                return
            ok = isinstance(reply, Ack) and reply.ok
            out["executed" if ok else "refused"] += 1
            out[f"answer: {reply.result if isinstance(reply, Ack) else reply.KIND}"] += 1

    await asyncio.gather(*(one(v, _hostile(rng, v)) for v in rng.choices(verbs, k=n)))
    out["tried"] = n
    return out


async def _strangers(endpoint: str, pki: Path) -> Counter:
    out: Counter = Counter(tried=0, refused=0, executed=0)
    links = {
        "no certificate": Transport("client", connect=(endpoint,), tls_ca=str(pki / "ca.crt")),
        "another CA": Transport(
            "client", connect=(endpoint,), **_tls(pki / "foreign", "alice", pki / "ca.crt")
        ),
        "clear tcp": Transport("client", connect=("tcp/" + endpoint.split("/", 1)[1],)),
    }
    for transport in links.values():
        out["tried"] += 1
        try:
            open_session(transport).close()
            out["executed"] += 1
        except zenoh.ZError:
            out["refused"] += 1
        await asyncio.sleep(0.15)  # the listener pauses 100 ms after a failed handshake
    tries: list[tuple[str, str, str]] = [("eve", "eve", v) for v in COMMANDS]
    tries += [("bob", "bob", v) for v in COMMANDS if not REQUESTS[v].READ_ONLY]
    tries += [("alice", "bob", v) for v in COMMANDS]
    for who, key, verb in tries:
        with RigClient.open(
            Transport("client", connect=(endpoint,), **_tls(pki, who)), RIG, who
        ) as c:
            out["tried"] += 1
            payload = encode(REQUESTS[verb].KIND, {}, src=key)
            try:
                reply = await c.call_raw(verb, payload, timeout=1.0, client=key)
                out["executed" if isinstance(reply, Ack) and reply.ok else "refused"] += 1
            except RigError:
                out["refused"] += 1
    # Fake telemetry from the operator: does the viewer ever see it?
    alice_t = Transport("client", connect=(endpoint,), **_tls(pki, "alice"))
    bob_t = Transport("client", connect=(endpoint,), **_tls(pki, "bob"))
    with RigClient.open(alice_t, RIG, "alice") as alice, RigClient.open(bob_t, RIG, "bob") as bob:
        states = bob.subscribe(bob.keys.ptu_state, PtuState)
        fake = encode(PtuState.KIND, PtuState(150.0, -40.0, False).to_body(), src=RIG)
        for _ in range(50):
            alice.session.put(alice.keys.ptu_state, fake)
            out["tried"] += 1
            await asyncio.sleep(0.02)
        await asyncio.sleep(0.3)
        seen = [states.get_nowait() for _ in range(states.qsize())]
        faked = sum(s.pan == 150.0 for s in seen)
        out["executed"] += faked
        out["refused"] += 50 - faked
    return out


async def _console(endpoint: str, pki: Path, log: Path) -> Counter:
    """Hostile HTTP against a real console (signed in where the attack would be)."""
    out: Counter = Counter(tried=0, refused=0, executed=0)
    link = ["--tls-ca", str(pki / "ca.crt"), "--tls-cert", str(pki / "alice.crt")]
    link += ["--tls-key", str(pki / "alice.key")]
    async with operator(endpoint, RIG, "alice", log, link) as url:
        base = url.split("?", 1)[0].rstrip("/")
        host = base.split("//", 1)[1]
        async with aiohttp.ClientSession() as http:
            async with http.get(url, allow_redirects=False) as r:
                cookie = r.cookies
            signed = {"Cookie": "; ".join(f"{k}={v.value}" for k, v in cookie.items())}
            evil = {"Origin": "http://evil.example"}
            rebind = {"Host": f"rebind.example:{host.rsplit(':', 1)[-1]}"}
            attempts = [
                ("post", "/api/control/take", {"headers": evil | signed, "json": {}}),
                ("post", "/api/ptu/goto", {"headers": evil, "json": {"pan": 9, "tilt": 1}}),
                ("post", "/api/control/take", {"headers": signed, "data": "{}"}),  # text/plain
                ("post", "/api/control/take", {"json": {}}),  # no cookie
                ("get", "/api/archive", {}),
                ("get", "/api/archive", {"headers": {"Host": "evil.example"} | signed}),
                ("post", "/api/control/take", {"headers": rebind | signed, "json": {}}),
            ]
            for method, path, kw in attempts * 20:
                out["tried"] += 1
                async with http.request(method, base + path, **kw) as r:
                    out["refused" if r.status in (401, 403, 415) else "executed"] += 1
            for _ in range(20):
                out["tried"] += 1
                try:
                    ws = await http.ws_connect(base + "/ws", headers=evil | signed)
                    await ws.close()
                    out["executed"] += 1
                except aiohttp.WSServerHandshakeError:
                    out["refused"] += 1
    return out


class _Frames:
    """A subscriber session recording each live frame's delivery latency."""

    def __init__(self, transport: Transport) -> None:
        self.session = open_session(transport)
        self.samples: list[float] = []
        self.sub = self.session.declare_subscriber(f"cyborg/{RIG}/cam/frame", on_thread(self._on))

    def _on(self, sample: zenoh.Sample) -> None:
        if sample.attachment is not None:
            self.samples.append((time.time_ns() - decode(sample.attachment.to_bytes()).ts) / 1e9)

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()


async def _frame_latency(transport: Transport, seconds: float) -> dict:
    frames = _Frames(transport)
    try:
        await asyncio.sleep(1.0)
        frames.samples.clear()
        await asyncio.sleep(seconds)
        return latency(frames.samples) | {"fps": len(frames.samples) / seconds}
    finally:
        frames.close()


async def _run(queries: int, seconds: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="bench-security-") as tmp:
        root = Path(tmp)
        pki = make_certificates(root / "pki", (RIG,), ("alice", "bob", "eve"))
        (pki / "users.toml").write_text(USERS)
        tls_ep = f"tls/127.0.0.1:{free_port()}"
        keys = {"listen": [tls_ep], **_tls(pki, RIG), "users": str(pki / "users.toml")}
        config = root / "cyborgd.toml"
        config.write_text(simulated_config(RIG, root / "archive", frame_rate=FPS, zenoh=keys))
        daemon: Daemon = await spawn(["--config", str(config)], root / "cyborgd.log")
        report: dict = {}
        try:
            rss0 = _rss_kib(daemon.pid)
            alice_t = Transport("client", connect=(tls_ep,), **_tls(pki, "alice"))
            with RigClient.open(alice_t, RIG, "alice") as alice:
                await alice.wait_alive()
                states = alice.subscribe(alice.keys.ptu_state, PtuState, maxsize=1)
                before = await states.get()
                t0 = time.perf_counter()
                report["hostile queries"] = await _hostile_queries(alice, queries, 600.0)
                report["hostile queries"]["seconds"] = round(time.perf_counter() - t0, 1)
                report["strangers"] = await _strangers(tls_ep, pki)
                report["console"] = await _console(tls_ep, pki, root / "operator.log")
                await alice.command(TakeControl())  # a still-working rig, after all that
                after = await states.get()
                moved = abs(after.pan - before.pan) + abs(after.tilt - before.tilt) > 0.01
                report["head moved"] = moved
            report["crashed"] = int(daemon.proc.returncode is not None)
            report["rss_kib"] = {"before": rss0, "after": _rss_kib(daemon.pid)}
            bob = Transport("client", connect=(tls_ep,), **_tls(pki, "bob"))
            report["frames"] = {"tls + acl": await _frame_latency(bob, seconds)}
        finally:
            await daemon.stop()
        # The same rig in clear text on loopback, no access list: the baseline.
        tcp_ep = f"tcp/127.0.0.1:{free_port()}"
        config.write_text(simulated_config(RIG, root / "archive", listen=[tcp_ep], frame_rate=FPS))
        daemon = await spawn(["--config", str(config)], root / "cyborgd-plain.log")
        try:
            plain = Transport("client", connect=(tcp_ep,))
            report["frames"] = {"plain tcp": await _frame_latency(plain, seconds)} | report[
                "frames"
            ]
        finally:
            await daemon.stop()
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.security", description=__doc__)
    ap.add_argument("--queries", type=int, default=10_000)
    ap.add_argument("--seconds", type=float, default=5.0, help="per frame-latency run")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    report = asyncio.run(_run(args.queries, args.seconds))
    if args.json:
        print(json.dumps(report, indent=1, default=dict))
        return 0
    print(f"{'attempts':<16} {'tried':>7} {'refused':>8} {'executed':>9}")
    for name in ("hostile queries", "strangers", "console"):
        c = report[name]
        print(f"{name:<16} {c['tried']:>7} {c['refused']:>8} {c['executed']:>9}")
    hq = report["hostile queries"]
    print(f"hostile queries took {hq['seconds']} s; not sent: {hq['not sent (time bound)']}")
    answers = sorted((k.split(": ", 1)[1], v) for k, v in hq.items() if k.startswith("answer: "))
    print("  answered " + ", ".join(f"{k} {v}" for k, v in answers))
    print(f"daemon crashed: {report['crashed']}; head moved by an attempt: {report['head moved']}")
    rss = report["rss_kib"]
    print(f"daemon RSS: {rss['before'] / 1024:.1f} MiB before, {rss['after'] / 1024:.1f} MiB after")
    f = report["frames"]
    print(f"live frames 720x576 JPEG at {FPS} fps, one subscriber, loopback:")
    for name, r in f.items():
        p50, p99 = r["median_ms"], r["p99_ms"]
        print(f"  {name:<10} p50 {p50:6.2f} ms  p99 {p99:6.2f} ms  {r['fps']:.1f} fps")
    ratio = f["tls + acl"]["median_ms"] / f["plain tcp"]["median_ms"]
    print(f"  TLS+ACL / plain, p50: {ratio:.2f}x")
    executed = sum(report[n]["executed"] for n in ("hostile queries", "strangers", "console"))
    return 0 if executed == 0 and not report["crashed"] else 1


if __name__ == "__main__":
    sys.exit(main())

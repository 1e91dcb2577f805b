"""Operator benchmark: live-frame latency daemon → browser page, and click → PTU motion.

The remote path, all real processes on loopback: ``cyborgd`` (PTU emulator on a pty,
simulated camera, live view at 25 fps) and ``cyborg operator`` both dial a zenoh router
run by this process; headless Chromium shows the page.

- **Frames:** the page's clock when a frame is drawn on its canvas minus the daemon's
  clock at publication (same host, same clock), p50/p99 measured in the page. Baseline,
  same run and same frames: a plain zenoh subscriber on the router.
- **Click → motion:** a real pointer click on the live view, from the page's click event
  to the first ``ptu/state`` saying the head moves, seen on the bus. Baseline: the same
  ``ptu/look`` sent straight over the bus by this process.

Usage: ``python -m bench.operator [--seconds 10] [--clicks 10] [--screenshot PNG] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
import tempfile
import time
from pathlib import Path

from bench.browser import MISSING, Browser, chromium
from bench.stats import latency
from cyborg.clients.launch import launch, operator, router, simulated_config
from cyborg.clients.rigclient import LiveFrame, RigClient
from cyborg.protocol.messages import PtuLook, PtuState, TakeControl
from cyborg.protocol.transport import Transport

FPS = 25
RIG = "opbench"


class _Motion:
    """Wall-clock ms of the first "moving" state after each arm()."""

    def __init__(self, client: RigClient) -> None:
        self.started: asyncio.Future[float] | None = None
        self.states = client.subscribe(client.keys.ptu_state, PtuState)
        self.task = asyncio.create_task(self._follow())

    async def _follow(self) -> None:
        while True:
            state: PtuState = await self.states.get()
            if state.moving and self.started is not None and not self.started.done():
                self.started.set_result(time.time() * 1e3)

    def arm(self) -> asyncio.Future[float]:
        self.started = asyncio.get_running_loop().create_future()
        return self.started

    async def still(self) -> None:
        await asyncio.sleep(0.3)
        while True:
            state = await self.states.get()
            if not state.moving and self.states.empty():
                return


async def _clicks(browser: Browser, client: RigClient, motion: _Motion, n: int) -> dict:
    page, bus = [], []
    width = browser.js("return document.getElementById('live').getBoundingClientRect().width;")
    for i in range(n):  # the bus baseline: ptu/look straight from this process
        await motion.still()
        side = 0.75 if i % 2 == 0 else 0.25
        started = motion.arm()
        t0 = time.time() * 1e3
        await client.command(PtuLook(side, 0.5, pan=0.0, tilt=0.0))
        bus.append((await asyncio.wait_for(started, 10) - t0) / 1e3)
    await asyncio.to_thread(browser.click, "#take")
    await asyncio.to_thread(browser.wait, "document.getElementById('reply').textContent")
    for i in range(n):
        await motion.still()
        await asyncio.sleep(0.3)  # a frame at the new pose is on the canvas
        started = motion.arm()
        dx = width / 4 if i % 2 == 0 else -width / 4
        await asyncio.to_thread(browser.click, "#live", dx, 0)
        moved = await asyncio.wait_for(started, 10)
        clicked = browser.js("return window.cyborgClickAt;")
        page.append((moved - clicked) / 1e3)
    return {"page": latency(page), "bus": latency(bus)}


async def _run(seconds: float, clicks: int, screenshot: Path | None) -> dict:
    with tempfile.TemporaryDirectory(prefix="bench-operator-") as tmp, router() as endpoint:
        config = Path(tmp) / "cyborgd.toml"
        config.write_text(
            simulated_config(RIG, Path(tmp) / "archive", connect=[endpoint], frame_rate=FPS)
        )
        async with launch(["--config", str(config)], Path(tmp) / "cyborgd.log"):
            with RigClient.open(Transport("client", connect=(endpoint,)), RIG, "bench") as client:
                await client.wait_alive()
                bus_frames: list[float] = []
                recording = False

                def on_frame(frame: LiveFrame) -> None:
                    if recording:
                        bus_frames.append(time.time() - frame.ts / 1e9)

                sub = client.frame_subscriber(on_frame)
                motion = _Motion(client)
                async with operator(
                    endpoint, RIG, "bench-operator", Path(tmp) / "operator.log"
                ) as url:
                    with chromium() as browser:
                        browser.open(url)
                        await asyncio.to_thread(browser.wait, "window.cyborgStats().frames >= 25")
                        browser.js("window.cyborgResetStats();")
                        recording = True
                        await asyncio.sleep(seconds)
                        recording = False
                        stats = browser.js("return window.cyborgStats();")
                        page = {"median_ms": stats["p50"], "p99_ms": stats["p99"]}
                        await client.command(TakeControl())
                        click = await _clicks(browser, client, motion, clicks)
                        if screenshot is not None:
                            await _survey_picture(browser, screenshot)
                motion.task.cancel()
                sub.undeclare()
    return {
        "fps": FPS,
        "seconds": seconds,
        "frames": {
            "page": page,
            "page_fps": stats["frames"] / seconds,
            "bus": latency(bus_frames),
            "bus_fps": len(bus_frames) / seconds,
        },
        "click_to_motion": click,
    }


async def _survey_picture(browser: Browser, path: Path) -> None:
    """The page after a survey, for the README."""
    await asyncio.to_thread(browser.click, "#survey")
    await asyncio.to_thread(
        browser.wait, "document.querySelectorAll('#chips img').length === 3", 120
    )
    await asyncio.sleep(1.0)
    browser.js("window.scrollTo(0, 0);")
    path.write_bytes(browser.screenshot())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.operator", description=__doc__)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--clicks", type=int, default=10)
    ap.add_argument("--screenshot", type=Path, help="save the page after a survey here")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if MISSING:
        print(f"bench.operator: {MISSING}", file=sys.stderr)
        return 2
    r = asyncio.run(_run(args.seconds, args.clicks, args.screenshot))
    if args.json:
        print(json.dumps(r, indent=1))
        return 0
    f, c = r["frames"], r["click_to_motion"]
    print(f"live frames 720x576 JPEG at {FPS} fps through a zenoh router, {args.seconds:g} s")
    print(f"{'path':<34} {'fps':>5} {'p50':>9} {'p99':>9}")
    print(
        f"{'daemon -> zenoh subscriber (base)':<34} {f['bus_fps']:5.1f} "
        f"{f['bus']['median_ms']:7.2f}ms {f['bus']['p99_ms']:7.2f}ms"
    )
    print(
        f"{'daemon -> operator -> page canvas':<34} {f['page_fps']:5.1f} "
        f"{f['page']['median_ms']:7.2f}ms {f['page']['p99_ms']:7.2f}ms"
    )
    print(f"page / bus p50: {f['page']['median_ms'] / f['bus']['median_ms']:.1f}x")
    print(f"\nclick -> PTU motion start, {args.clicks} clicks")
    print(
        f"{'ptu/look from a bus client (base)':<34} {c['bus']['median_ms']:7.1f}ms "
        f"{c['bus']['p99_ms']:7.1f}ms"
    )
    print(
        f"{'click on the page live view':<34} {c['page']['median_ms']:7.1f}ms "
        f"{c['page']['p99_ms']:7.1f}ms"
    )
    print(f"page / bus p50: {c['page']['median_ms'] / c['bus']['median_ms']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())

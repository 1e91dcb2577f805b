"""Headless Chromium driven over the W3C WebDriver protocol (Debian's chromedriver), with
nothing but the standard library: the operator page's tests and its latency benchmark.

Chromium runs with the flags a closed, root-run machine needs: no sandbox, no GPU, no
background networking (its own update and sync requests would be refused by the dozen).
"""

from __future__ import annotations

import base64
import contextlib
import json
import shutil
import socket
import subprocess
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from typing import Any

__all__ = ["MISSING", "Browser", "chromium"]

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
MISSING = (
    None
    if CHROMIUM and CHROMEDRIVER
    else "headless Chromium not found: install Debian's `chromium` and `chromium-driver` "
    "(sudo apt-get install chromium chromium-driver) to run the operator page tests"
)
_ELEMENT = "element-6066-11e4-a52e-4f735466cecf"  # the W3C web element key
_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1400,1000",
]


class Browser:
    """One WebDriver session."""

    def __init__(self, endpoint: str, session: str) -> None:
        self.endpoint = endpoint
        self.session = session

    def _call(self, method: str, path: str, body: Any = None) -> Any:
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(
            f"{self.endpoint}/session/{self.session}{path}",
            data=data,
            method=method,
            headers={"content-type": "application/json"},
        )
        try:
            with urllib.request.urlopen(req, timeout=60) as reply:
                return json.load(reply)["value"]
        except urllib.error.HTTPError as exc:
            raise RuntimeError(f"webdriver {path}: {exc.read().decode(errors='replace')}") from None

    def open(self, url: str) -> None:
        self._call("POST", "/url", {"url": url})

    def js(self, script: str, *args: Any) -> Any:
        """Run ``script`` as a function body in the page; ``arguments[i]`` are ``args``."""
        return self._call("POST", "/execute/sync", {"script": script, "args": list(args)})

    def wait(self, script: str, timeout: float = 30.0, *args: Any) -> Any:
        """Poll a JS expression until it is truthy; returns its value."""
        deadline = time.monotonic() + timeout
        error = ""
        while True:
            try:  # a page still loading may not define what the script uses yet
                if value := self.js(f"return ({script});", *args):
                    return value
            except RuntimeError as exc:
                error = f" (last error: {exc})"
            if time.monotonic() > deadline:
                raise TimeoutError(f"the page never satisfied {script}{error}")
            time.sleep(0.05)

    def click(self, selector: str, dx: float = 0.0, dy: float = 0.0) -> None:
        """A real pointer click at (dx, dy) CSS pixels from the element's centre."""
        found = self._call("POST", "/element", {"using": "css selector", "value": selector})
        origin = {_ELEMENT: found[_ELEMENT]}
        self.js("arguments[0].scrollIntoView({block: 'center', inline: 'center'});", origin)
        pointer = [
            {"type": "pointerMove", "origin": origin, "x": round(dx), "y": round(dy)},
            {"type": "pointerDown", "button": 0},
            {"type": "pointerUp", "button": 0},
        ]
        actions = [{"type": "pointer", "id": "mouse", "actions": pointer}]
        self._call("POST", "/actions", {"actions": actions})

    def console(self) -> list[dict[str, Any]]:
        """The browser log since the last call: console messages, failed loads, CSP
        violations (``level`` SEVERE for the errors)."""
        return self._call("POST", "/se/log", {"type": "browser"})

    def print_pdf(self) -> bytes:
        """The page printed to A4 (WebDriver's print command), as PDF bytes."""
        doc = self._call("POST", "/print", {"page": {"width": 21.0, "height": 29.7}})
        return base64.b64decode(doc)

    def screenshot(self) -> bytes:
        return base64.b64decode(self._call("GET", "/screenshot"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def chromium() -> Iterator[Browser]:
    """A headless Chromium session, closed with its driver and profile at the end."""
    if MISSING:
        raise RuntimeError(MISSING)
    port = _free_port()
    driver = subprocess.Popen(
        [CHROMEDRIVER, f"--port={port}", "--allowed-ips=127.0.0.1"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    endpoint = f"http://127.0.0.1:{port}"
    try:
        with tempfile.TemporaryDirectory(prefix="cyborg-chromium-") as profile:
            deadline = time.monotonic() + 20
            while True:
                with (
                    contextlib.suppress(OSError),
                    urllib.request.urlopen(f"{endpoint}/status", timeout=2) as r,
                ):
                    if json.load(r)["value"]["ready"]:
                        break
                if time.monotonic() > deadline:
                    raise RuntimeError("chromedriver did not start")
                time.sleep(0.1)
            caps = {
                "capabilities": {
                    "alwaysMatch": {
                        "browserName": "chrome",
                        "goog:loggingPrefs": {"browser": "ALL"},
                        "goog:chromeOptions": {
                            "binary": CHROMIUM,
                            "args": [*_FLAGS, f"--user-data-dir={profile}"],
                        },
                    }
                }
            }
            req = urllib.request.Request(
                f"{endpoint}/session",
                data=json.dumps(caps).encode(),
                method="POST",
                headers={"content-type": "application/json"},
            )
            with urllib.request.urlopen(req, timeout=60) as reply:
                session = json.load(reply)["value"]["sessionId"]
            browser = Browser(endpoint, session)
            try:
                yield browser
            finally:
                with contextlib.suppress(OSError, RuntimeError):
                    browser._call("DELETE", "")
    finally:
        driver.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            driver.wait(10)
        if driver.poll() is None:
            driver.kill()

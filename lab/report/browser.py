"""Open a report page in a real browser: Debian's headless Chromium over the DevTools Protocol.

:class:`Chromium` starts ``chromium --headless`` with a private profile and a debugging port the
browser picks (written to ``DevToolsActivePort``), and talks to its page over a WebSocket
(``websocket-client``). :meth:`Chromium.load` navigates to a file, waits for its load event and
returns every image's natural size and every console error, uncaught exception and failed load
the page caused; :meth:`Chromium.screenshot` captures the whole page as PNG.

``python -m lab.report.browser reports/tiny/index.html --screenshot shot.png`` checks a page
by hand (exit 1 when an image is broken or the console has errors). ``make test`` installs
Debian's ``chromium`` when it is missing.
"""
from __future__ import annotations

import argparse
import base64
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

__all__ = ["Chromium", "find_chromium", "PageCheck"]

START_TIMEOUT_S = 30.0   # a cold Chromium start on a busy 2-core machine takes a few seconds
LOAD_TIMEOUT_S = 60.0


def find_chromium() -> str | None:
    """The Chromium executable on PATH (Debian's ``chromium``), or None."""
    return next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)


class PageCheck(dict):
    """What :meth:`Chromium.load` saw: ``images`` (src, complete, natural width and height) and
    ``errors`` (one line each); ``broken`` lists the images that did not load."""

    @property
    def broken(self) -> list:
        return [i for i in self["images"] if not i["complete"] or i["width"] == 0]


class Chromium:
    """A headless Chromium with one page, driven over the DevTools Protocol (a context manager)."""

    def __init__(self, executable: str | None = None, width: int = 1280, height: int = 900):
        self.executable = executable or find_chromium()
        if self.executable is None:
            raise RuntimeError("chromium not found: install Debian's package (apt-get install -y chromium; "
                               "`make test` does it)")
        self.width, self.height = width, height
        self._ids = itertools.count(1)
        self.events: list[dict] = []

    def __enter__(self):
        import websocket

        self._profile = tempfile.TemporaryDirectory(prefix="splatlab-chromium-")
        self._proc = subprocess.Popen(
            [self.executable, "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--no-default-browser-check", "--hide-scrollbars", "--remote-debugging-port=0",
             "--allow-file-access-from-files", f"--user-data-dir={self._profile.name}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            page = self._page(self._port())
            self._ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=LOAD_TIMEOUT_S,
                                                   suppress_origin=True)
            for method in ("Page.enable", "Runtime.enable", "Log.enable"):
                self.call(method)
            self.call("Emulation.setDeviceMetricsOverride", width=self.width, height=self.height,
                      deviceScaleFactor=1, mobile=False)
        except BaseException:
            self._stop()
            raise
        return self

    def __exit__(self, *exc):
        self._stop()

    def _port(self) -> int:
        marker = Path(self._profile.name) / "DevToolsActivePort"
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self._proc.poll() is not None:
                raise RuntimeError(f"{self.executable} exited with {self._proc.returncode} at start-up")
            if marker.exists() and marker.read_text().strip():
                return int(marker.read_text().split()[0])
            time.sleep(0.05)
        raise RuntimeError(f"{self.executable} did not open its debugging port in {START_TIMEOUT_S:g} s")

    def _page(self, port: int) -> dict:
        """The first page target; Chromium may open its debugging port before it lists the page."""
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
                pages = [t for t in json.load(r) if t.get("type") == "page"]
            if pages:
                return pages[0]
            if time.monotonic() > deadline:
                raise RuntimeError(f"{self.executable} listed no page target in {START_TIMEOUT_S:g} s")
            time.sleep(0.05)

    def _stop(self) -> None:
        ws = getattr(self, "_ws", None)
        if ws is not None:
            ws.close()
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(10)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        # its helpers (renderer, crashpad) can outlive it and still write into the profile, which
        # made the clean-up fail ("Directory not empty") on a loaded machine: end its whole session
        try:
            os.killpg(self._proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        for attempt in range(50):
            try:
                self._profile.cleanup()
                return
            except OSError:
                if attempt == 49:
                    raise
                time.sleep(0.1)

    def call(self, method: str, **params) -> dict:
        """Send one command and return its result; events that arrive meanwhile are kept."""
        ident = next(self._ids)
        self._ws.send(json.dumps({"id": ident, "method": method, "params": params}))
        while True:
            message = json.loads(self._ws.recv())
            if message.get("id") == ident:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
            self.events.append(message)

    def _wait_for(self, event: str) -> None:
        deadline = time.monotonic() + LOAD_TIMEOUT_S
        while not any(e.get("method") == event for e in self.events):
            if time.monotonic() > deadline:
                raise RuntimeError(f"no {event} within {LOAD_TIMEOUT_S:g} s")
            self.events.append(json.loads(self._ws.recv()))

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page (JSON-able)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression[:60]}...: {result['exceptionDetails'].get('text')}")
        return result["result"].get("value")

    def load(self, path) -> PageCheck:
        """Open ``path`` (a file), wait for its load event; its images and console errors."""
        self.events.clear()
        self.call("Page.navigate", url=Path(path).resolve().as_uri())
        self._wait_for("Page.loadEventFired")
        images = self.evaluate("Array.from(document.images).map(i => ({src: i.getAttribute('src'), "
                               "complete: i.complete, width: i.naturalWidth, height: i.naturalHeight}))")
        return PageCheck(images=images, errors=self.errors())

    def errors(self) -> list[str]:
        """Console errors, uncaught exceptions and failed loads seen since the last :meth:`load`."""
        out = []
        for e in self.events:
            method, p = e.get("method"), e.get("params", {})
            if method == "Runtime.exceptionThrown":
                d = p["exceptionDetails"]
                out.append(f"exception: {d.get('exception', {}).get('description') or d.get('text')}")
            elif method == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                out.append("console.error: " + " ".join(str(a.get("value", a.get("description"))) for a in p["args"]))
            elif method == "Log.entryAdded" and p["entry"].get("level") == "error":
                out.append(f"log: {p['entry'].get('text')} {p['entry'].get('url', '')}".strip())
        return out

    def screenshot(self, path) -> Path:
        """The whole page (all of its height) as a PNG at ``path``."""
        size = self.call("Page.getLayoutMetrics")["cssContentSize"]
        shot = self.call("Page.captureScreenshot", format="png", captureBeyondViewport=True,
                         clip={"x": 0, "y": 0, "width": self.width, "height": size["height"], "scale": 1})
        path = Path(path)
        path.write_bytes(base64.b64decode(shot["data"]))
        return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m lab.report.browser", description=__doc__.split("\n\n")[0])
    parser.add_argument("page", type=Path, help="an HTML file, e.g. reports/tiny/index.html")
    parser.add_argument("--screenshot", type=Path, help="write the whole page as PNG here")
    args = parser.parse_args(argv)
    with Chromium() as browser:
        check = browser.load(args.page)
        if args.screenshot:
            browser.screenshot(args.screenshot)
    print(f"{args.page}: {len(check['images'])} images, {len(check.broken)} broken, {len(check['errors'])} errors")
    for line in [f"broken image: {i['src']}" for i in check.broken] + check["errors"]:
        print(f"  {line}")
    return 1 if check.broken or check["errors"] else 0


if __name__ == "__main__":
    sys.exit(main())

"""A headless Chromium driven over the Chrome DevTools Protocol (no WebDriver needed).

The browser is started with ``--headless --no-sandbox --disable-gpu`` and no background
networking; pages are opened from ``file://`` URLs. For each page the client records
every request the page makes, console messages, uncaught exceptions and browser log
entries, so a test can assert that a report loads nothing from the network and logs no
error. Only the DevTools endpoint on 127.0.0.1 is contacted.
"""

from __future__ import annotations

import base64
import io
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-default-apps",
    "--disable-extensions",
    "--disable-sync",
    "--disable-features=Translate,MediaRouter,OptimizationHints",
    "--no-first-run",
    "--no-default-browser-check",
    "--metrics-recording-only",
    "--mute-audio",
    "--hide-scrollbars",
    "--remote-debugging-port=0",
    "--remote-allow-origins=*",
)
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_chromium() -> str | None:
    """``$MTM_CHROMIUM`` or the first Chromium/Chrome on PATH."""
    named = os.environ.get("MTM_CHROMIUM")
    if named:
        return shutil.which(named)
    return next((p for p in map(shutil.which, CANDIDATES) if p), None)


@dataclass
class PageLoad:
    """What happened while a page loaded, and the figures found in it."""

    url: str
    requests: list[str] = field(default_factory=list)
    console_errors: list[str] = field(default_factory=list)
    figures: list[dict] = field(default_factory=list)
    title: str = ""


class Chromium:
    """One headless browser process and one page (tab) driven over its DevTools socket."""

    def __init__(self, executable: str, timeout: float = 30.0) -> None:
        import websocket  # websocket-client (test extra)

        self._profile = tempfile.mkdtemp(prefix="mtm-chromium-")
        self._process = subprocess.Popen(
            [executable, *FLAGS, f"--user-data-dir={self._profile}", "about:blank"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        port = self._wait_for_port(timeout)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=timeout) as r:
            pages = [t for t in json.load(r) if t["type"] == "page"]
        self._socket = websocket.create_connection(
            pages[0]["webSocketDebuggerUrl"], timeout=timeout, suppress_origin=True
        )
        self._next_id = 0
        self._events: list[dict] = []
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.send(f"{domain}.enable")

    def _wait_for_port(self, timeout: float) -> int:
        marker = Path(self._profile) / "DevToolsActivePort"
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                raise RuntimeError(f"Chromium exited with code {self._process.returncode}")
            if marker.exists():
                text = marker.read_text().split()
                if text:
                    return int(text[0])
            time.sleep(0.05)
        raise TimeoutError("Chromium did not open its DevTools port")

    def send(self, method: str, **params) -> dict:
        """Call a DevTools method and return its result (events are kept for later)."""
        self._next_id += 1
        ident = self._next_id
        self._socket.send(json.dumps({"id": ident, "method": method, "params": params}))
        while True:
            message = json.loads(self._socket.recv())
            if message.get("id") == ident:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
            if "method" in message:
                self._events.append(message)

    def _wait_event(self, method: str) -> None:
        while not any(e["method"] == method for e in self._events):
            message = json.loads(self._socket.recv())
            if "method" in message:
                self._events.append(message)

    def evaluate(self, expression: str):
        """The JSON value of a JavaScript expression in the page."""
        result = self.send("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"script failed: {result['exceptionDetails']}")
        return result["result"].get("value")

    def load(self, path: Path, width: int = 1200) -> PageLoad:
        """Open a local HTML file, wait for its load event, collect what happened."""
        self.send(
            "Emulation.setDeviceMetricsOverride",
            width=width,
            height=900,
            deviceScaleFactor=1,
            mobile=False,
        )
        self._events.clear()
        url = Path(path).resolve().as_uri()
        self.send("Page.navigate", url=url)
        self._wait_event("Page.loadEventFired")
        time.sleep(0.1)  # let late console messages arrive
        self.send("Runtime.evaluate", expression="0")  # flush pending events
        load = PageLoad(url=url, title=self.evaluate("document.title"))
        for event in self._events:
            method, params = event["method"], event["params"]
            if method == "Network.requestWillBeSent":
                load.requests.append(params["request"]["url"])
            elif method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                load.console_errors.append(json.dumps(params["args"])[:300])
            elif method == "Runtime.exceptionThrown":
                load.console_errors.append(params["exceptionDetails"].get("text", "exception"))
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                load.console_errors.append(params["entry"].get("text", "")[:300])
        load.figures = self.evaluate(FIGURES_SCRIPT)
        return load

    def screenshot(self, path: Path) -> bytes:
        """A full-page PNG, written to ``path`` and returned."""
        height = int(self.evaluate("document.documentElement.scrollHeight"))
        width = int(self.evaluate("document.documentElement.scrollWidth"))
        self.send(
            "Emulation.setDeviceMetricsOverride",
            width=width,
            height=height,
            deviceScaleFactor=1,
            mobile=False,
        )
        data = base64.b64decode(self.send("Page.captureScreenshot", format="png")["data"])
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        return data

    def print_pdf(self) -> bytes:
        """The page printed to PDF (A4, print style sheet)."""
        result = self.send("Page.printToPDF", paperWidth=8.27, paperHeight=11.69)
        return base64.b64decode(result["data"])

    def close(self) -> None:
        try:
            self._socket.close()
        finally:
            self._process.terminate()
            try:
                self._process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._process.kill()
            shutil.rmtree(self._profile, ignore_errors=True)


# Each report figure: its number, the size of its SVG on the page, how many drawn
# elements (paths, text, images ...) it holds, its caption, and what is cut off:
# ``outside`` lists the texts and drawn elements whose box leaves the SVG's viewport,
# ``clipped`` the markers (matplotlib's <use>: balls, points) cut by their axes' clip
# rectangle (a marker half outside its axes), ``texts`` every text drawn.
FIGURES_SCRIPT = """
Array.from(document.querySelectorAll('figure.mtm-figure')).map(f => {
  const svg = f.querySelector('svg');
  const r = svg ? svg.getBoundingClientRect() : {x: 0, y: 0, width: 0, height: 0};
  const caption = f.querySelector('figcaption');
  const out = {number: f.dataset.figure, width: r.width, height: r.height,
          x: r.x + window.scrollX, y: r.y + window.scrollY,
          drawn: svg ? svg.querySelectorAll('path, text, image, use, line, polygon').length : 0,
          caption: caption ? caption.textContent.trim() : '', outside: [], clipped: [],
          texts: []};
  if (!svg) return out;
  const tol = 0.5;
  const inside = (b, c) => b.left >= c.left - tol && b.right <= c.right + tol &&
                           b.top >= c.top - tol && b.bottom <= c.bottom + tol;
  const label = e => e.tagName + ' ' + (e.textContent || e.getAttribute('xlink:href') ||
                                         e.getAttribute('href') || '').trim().slice(0, 40);
  for (const e of svg.querySelectorAll('text, use, image, path, line, polygon')) {
    if (e.closest('defs, clipPath')) continue;
    const b = e.getBoundingClientRect();
    if (b.width === 0 && b.height === 0) continue;
    if (e.tagName === 'text') out.texts.push(e.textContent.trim());
    // clipped drawing (data lines, spans) may extend past the viewport: only its visible
    // part counts, so elements under a clip-path are checked against the clip instead
    const holder = e.closest('[clip-path]');
    if (!holder) {
      if (!inside(b, r)) out.outside.push(label(e));
      continue;
    }
    if (e.tagName !== 'use') continue;
    const id = holder.getAttribute('clip-path').match(/#([^)"']+)/)[1];
    const rect = svg.querySelector('clipPath[id="' + id + '"] rect');
    if (!rect) continue;
    const m = holder.getScreenCTM();
    const p = (x, y) => new DOMPoint(x, y).matrixTransform(m);
    const x0 = +rect.getAttribute('x'), y0 = +rect.getAttribute('y');
    const a = p(x0, y0), z = p(x0 + +rect.getAttribute('width'),
                               y0 + +rect.getAttribute('height'));
    const c = {left: Math.min(a.x, z.x), right: Math.max(a.x, z.x),
               top: Math.min(a.y, z.y), bottom: Math.max(a.y, z.y)};
    if (!inside(b, c)) out.clipped.push(label(e));
  }
  return out;
})
"""


def decode_png(png: bytes):
    """The RGB pixels of a PNG, floats in [0, 1], shape (height, width, 3)."""
    from matplotlib.image import imread

    return imread(io.BytesIO(png))[..., :3]


def ink_fraction(image, box: dict) -> float:
    """Fraction of the pixels of ``image`` inside ``box`` (page coordinates) not white."""
    y0, x0 = int(box["y"]), int(box["x"])
    crop = image[y0 : y0 + int(box["height"]), x0 : x0 + int(box["width"])]
    if crop.size == 0:
        return 0.0
    return float((crop.min(axis=-1) < 0.95).mean())

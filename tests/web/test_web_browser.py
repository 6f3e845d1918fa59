"""The web application in a real browser: Debian's Chromium, headless, driven over the
DevTools protocol by the harness of the report tests (tests/report/chromium.py).

The application runs under uvicorn on a free loopback port over a SQLite history. Each page
must load with no console error and no uncaught exception (a Content-Security-Policy
violation — an inline script or style — is one) and request nothing outside the server.
Without Chromium the tests skip with the reason; with ``MTM_REQUIRE_BROWSER=1`` (``.ci/run``)
they fail instead.
"""

from __future__ import annotations

import importlib.util
import json
import os
import socket
import sys
import threading
import time
from pathlib import Path

import pytest
from webtools import MACHINE, PASSWORD, Lab, calibration

_spec = importlib.util.spec_from_file_location(
    "mtm_chromium", Path(__file__).resolve().parents[1] / "report" / "chromium.py"
)
chromium = sys.modules.setdefault("mtm_chromium", importlib.util.module_from_spec(_spec))
_spec.loader.exec_module(chromium)  # registered first: its dataclasses look their module up


class Browser(chromium.Chromium):
    """The report harness's browser, navigating to URLs and submitting forms."""

    def _collect(self) -> list[str]:
        time.sleep(0.2)  # late console messages and htmx swaps
        self.send("Runtime.evaluate", expression="0")
        errors = []
        for event in self._events:
            method, params = event["method"], event["params"]
            if method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                errors.append(json.dumps(params["args"])[:300])
            elif method == "Runtime.exceptionThrown":
                errors.append(params["exceptionDetails"].get("text", "exception"))
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                text = params["entry"].get("text", "")
                # an HTTP error status the test asks for is logged too; it is not a page error
                if "the server responded with a status of 403" not in text:
                    errors.append(text[:300])
        return errors

    def requests(self) -> list[str]:
        return [
            e["params"]["request"]["url"]
            for e in self._events
            if e["method"] == "Network.requestWillBeSent"
        ]

    def go(self, url: str) -> list[str]:
        """Open ``url``; the console errors of its load."""
        self._events.clear()
        self.send("Page.navigate", url=url)
        self._wait_event("Page.loadEventFired")
        return self._collect()

    def submit(self, script: str) -> list[str]:
        """Run ``script`` (which submits a form) and wait for the next page."""
        self._events.clear()
        self.send("Runtime.evaluate", expression=script)
        self._wait_event("Page.loadEventFired")
        return self._collect()

    def wait_for(self, expression: str, timeout: float = 10.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            value = self.evaluate(expression)
            if value:
                return value
            time.sleep(0.1)
        raise AssertionError(f"timed out waiting for {expression}")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """The application under uvicorn over a filled SQLite history: its base URL."""
    import uvicorn

    folder = tmp_path_factory.mktemp("web-browser")
    lab = Lab(f"sqlite:///{folder / 'history.sqlite'}")
    (folder / "upload.json").write_text(json.dumps(calibration([9.0] * 13)))
    port = _free_port()
    instance = uvicorn.Server(
        uvicorn.Config(lab.app, host="127.0.0.1", port=port, log_level="warning")
    )
    thread = threading.Thread(target=instance.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not instance.started and time.monotonic() < deadline:
        time.sleep(0.05)
    assert instance.started, "uvicorn did not start"
    yield f"http://127.0.0.1:{port}", folder / "upload.json"
    instance.should_exit = True
    thread.join(timeout=10)


@pytest.fixture(scope="module")
def browser():
    executable = chromium.find_chromium()
    missing = None
    if executable is None:
        missing = "Chromium not found (Debian: apt-get install chromium; or set MTM_CHROMIUM)"
    elif importlib.util.find_spec("websocket") is None:
        missing = "websocket-client not installed (pip install -e '.[test]')"
    if missing:
        if os.environ.get("MTM_REQUIRE_BROWSER") == "1":
            pytest.fail(f"MTM_REQUIRE_BROWSER=1 but {missing}")
        pytest.skip(f"browser checks skipped: {missing}")
    instance = Browser(executable)
    yield instance
    instance.close()


def _login(browser, base: str, user: str) -> list[str]:
    errors = browser.go(f"{base}/login")
    errors += browser.submit(
        f"document.querySelector('[name=username]').value = {json.dumps(user)};"
        f"document.querySelector('[name=password]').value = {json.dumps(PASSWORD)};"
        "document.getElementById('login').requestSubmit();"
    )
    return errors


def test_a_lab_in_the_browser(browser, server):
    base, upload_file = server
    # login, then the machines list
    assert _login(browser, base, "engineer") == []
    assert browser.evaluate("location.pathname") == "/machines"
    rows = browser.evaluate(
        "[...document.querySelectorAll('#machines tr[data-machine]')].map(r => r.dataset.machine)"
    )
    assert rows == [MACHINE.name]
    # the filter (htmx, no inline script) narrows the list without a page load
    browser.evaluate(
        "const q = document.getElementById('q'); q.value = 'no-such-machine';"
        "q.dispatchEvent(new Event('input', {bubbles: true})); 0"
    )
    browser.wait_for("document.querySelectorAll('#machines tr[data-machine]').length === 0")
    assert browser._collect() == []
    # a machine's trend: the control chart drawn, then another parameter's through htmx
    assert browser.go(f"{base}/machines/{MACHINE.name}") == []
    assert browser.wait_for("document.querySelector('#trend img').naturalWidth") > 300
    browser.evaluate(
        "[...document.querySelectorAll('#parameters a')].find(a => a.textContent === 'E_X0C')"
        ".click(); 0"
    )
    browser.wait_for("document.querySelector('#trend').dataset.parameter === 'E_X0C'")
    assert browser.wait_for("document.querySelector('#trend img').naturalWidth") > 300
    # a run's report, embedded; its figures render
    assert browser.go(f"{base}/runs/calibration/2") == []
    report_url = f"{base}/runs/calibration/2/report.html"
    assert browser.evaluate("document.getElementById('report').src") == report_url
    framed = [
        e["params"]["response"]["status"]
        for e in browser._events
        if e["method"] == "Network.responseReceived"
        and e["params"]["response"]["url"] == report_url
    ]
    assert framed == [200]  # the frame loaded the report
    load = browser.go(f"{base}/runs/calibration/2/report.html")
    assert load == []
    figures = browser.evaluate(chromium.FIGURES_SCRIPT)
    assert figures and all(f["width"] > 100 and f["drawn"] > 5 for f in figures)
    # an upload (the file input set through the DevTools protocol)
    assert browser.go(f"{base}/upload") == []
    document = browser.send("DOM.getDocument")["root"]["nodeId"]
    node = browser.send("DOM.querySelector", nodeId=document, selector="input[type=file]")
    browser.send("DOM.setFileInputFiles", nodeId=node["nodeId"], files=[str(upload_file)])
    errors = browser.submit(
        "document.querySelector('[name=note]').value = 'from the browser';"
        "document.getElementById('upload').requestSubmit();"
    )
    assert errors == []
    assert browser.evaluate("location.pathname") == "/runs/calibration/7"
    assert browser.evaluate("document.getElementById('note').textContent") == "from the browser"
    # nothing was requested from anywhere but the server
    assert all(u.startswith(base) or u.startswith("data:") for u in browser.requests())
    assert browser.submit("document.getElementById('logout').click()") == []
    assert browser.evaluate("location.pathname") == "/login"


def test_a_viewer_is_refused_an_upload(browser, server):
    base, _ = server
    assert _login(browser, base, "viewer") == []
    assert browser.evaluate("document.querySelector('header a[href=\"/upload\"]')") is None
    browser.go(f"{base}/upload")
    assert browser.evaluate("document.getElementById('error').dataset.status") == "403"
    assert browser.evaluate("document.querySelector('input[type=file]')") is None

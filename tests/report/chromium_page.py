"""A page loaded in headless Chromium over the DevTools protocol, as a reader's browser
sees it.

:func:`open_page` starts Chromium (the distribution's package: ``apt-get install
chromium``) with a fresh profile and no background networking, talks to it over its
DevTools pipe (``--remote-debugging-pipe``: JSON messages on file descriptors 3 and 4, so
no port and no websocket library), loads a file and returns every console error and
uncaught exception, every request that was not the page itself or an embedded image, and
what an inspection script found there (by default each image's decoding and each table
cell with its attributes, ``data-path``...). Where Chromium is not installed the calling
test skips, saying so.
"""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import pytest

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--remote-debugging-pipe")
TIMEOUT = 120.0
"""Seconds to wait for a message from Chromium (a failure, not a time measured: the
machine is shared)."""

# What the page holds once loaded: every image decoded (or why not) and every table cell.
INSPECT = """(async () => {
  const images = await Promise.all([...document.images].map(img => img.decode().then(
    () => ({ok: true, width: img.naturalWidth, alt: img.alt}),
    e => ({ok: false, alt: img.alt, error: String(e)}))));
  const cells = [...document.querySelectorAll("td")].map(td => ({
    table: td.closest("table").dataset.table, row: td.parentElement.cells[0].textContent,
    text: td.textContent, ...Object.assign({}, td.dataset)}));
  const tables = [...document.querySelectorAll("table")].map(t => t.dataset.table);
  const summary = document.querySelector("#summary").textContent;
  return JSON.stringify({images, cells, tables, summary});
})()"""


def chromium() -> str | None:
    """The Chromium executable, or None."""
    return next((p for p in map(shutil.which, BROWSERS) if p), None)


class DevTools:
    """A running Chromium driven over its DevTools pipe: :meth:`call` writes to its fd 3
    and reads its fd 4 (each message ends with a NUL byte); :meth:`attach` then talks to
    its page."""

    def __init__(self, write: int, read: int) -> None:
        self.write, self.read = write, read
        self.buffer = b""
        self.next_id = 0
        self.session: str | None = None
        self.events: list[dict[str, Any]] = []

    def recv(self) -> dict[str, Any]:
        while b"\0" not in self.buffer:
            ready, _, _ = select.select([self.read], [], [], TIMEOUT)
            chunk = os.read(self.read, 1 << 20) if ready else b""
            if not chunk:
                raise RuntimeError("Chromium stopped answering" if ready else
                                   f"no message from Chromium in {TIMEOUT:g} s")
            self.buffer += chunk
        message, _, self.buffer = self.buffer.partition(b"\0")
        return json.loads(message)

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        self.next_id += 1
        message: dict[str, Any] = {"id": self.next_id, "method": method, "params": params}
        if self.session is not None:
            message["sessionId"] = self.session
        os.write(self.write, json.dumps(message).encode() + b"\0")
        while True:
            msg = self.recv()
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]
            self.events.append(msg)

    def attach(self) -> None:
        """Talk to the browser's page from now on."""
        targets = self.call("Target.getTargets")["targetInfos"]
        page = next(t["targetId"] for t in targets if t["type"] == "page")
        self.session = self.call("Target.attachToTarget", targetId=page,
                                 flatten=True)["sessionId"]

    def wait(self, method: str) -> None:
        while not any(e.get("method") == method for e in self.events):
            self.events.append(self.recv())


def _start(exe: str, profile: Path) -> tuple[subprocess.Popen, DevTools]:
    """Chromium with its DevTools pipe on fds 3 (it reads) and 4 (it writes)."""
    to_browser, from_us = os.pipe()
    to_us, from_browser = os.pipe()

    def pipes() -> None:  # in the child, before exec
        os.dup2(to_browser, 3)
        os.dup2(from_browser, 4)

    proc = subprocess.Popen([exe, *FLAGS, f"--user-data-dir={profile}", "about:blank"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            pass_fds=(3, 4), preexec_fn=pipes)
    os.close(to_browser)
    os.close(from_browser)
    return proc, DevTools(from_us, to_us)


def _problems(events: list[dict[str, Any]]) -> tuple[list[str], list[str]]:
    """Console errors and uncaught exceptions; requests for anything but the page and
    data URIs."""
    errors, requests = [], []
    for e in events:
        method, p = e.get("method"), e.get("params", {})
        if method == "Runtime.exceptionThrown":
            details = p["exceptionDetails"]
            errors.append(f"{details.get('text', 'exception')} "
                          f"{details.get('exception', {}).get('description', '')}")
        elif method == "Runtime.consoleAPICalled" and p["type"] in ("error", "assert"):
            errors.append(" ".join(str(a.get("value", a.get("description"))) for a in p["args"]))
        elif method == "Log.entryAdded" and p["entry"]["level"] == "error":
            errors.append(p["entry"]["text"])
        elif method == "Network.requestWillBeSent":
            url = p["request"]["url"]
            if not url.startswith(("file:", "data:")):
                requests.append(url)
    return errors, requests


def open_page(path: Path, script: str = INSPECT) -> dict[str, Any]:
    """Load ``path`` in headless Chromium; the console errors (``errors``), the requests
    that left the page (``requests``) and what ``script`` returned (JSON), merged."""
    exe = chromium()
    if exe is None:
        pytest.skip("Chromium is not installed (apt-get install chromium)")
    profile = Path(tempfile.mkdtemp(prefix="cml-edge-chromium-"))
    proc, tools = _start(exe, profile)
    try:
        tools.attach()
        for domain in ("Runtime", "Log", "Network", "Page"):
            tools.call(f"{domain}.enable")
        tools.call("Page.navigate", url=path.resolve().as_uri())
        tools.wait("Page.loadEventFired")
        found = tools.call("Runtime.evaluate", expression=script, awaitPromise=True,
                           returnByValue=True)
        if "exceptionDetails" in found:
            raise RuntimeError(f"the inspection failed: {found['exceptionDetails']}")
        errors, requests = _problems(tools.events)
        return {**json.loads(found["result"]["value"]), "errors": errors,
                "requests": requests}
    finally:
        os.close(tools.write)
        os.close(tools.read)
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
        shutil.rmtree(profile, ignore_errors=True)

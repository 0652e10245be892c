"""The explorer page in headless Chromium (Playwright with the system browser), for its test and benchmark.

Playwright drives the Chromium the system has (Debian: ``apt-get install -y chromium``); it never
downloads a browser. :func:`open_page` opens a page with a fresh profile and records its console
messages and requests.
"""

from __future__ import annotations

import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["CHROMIUM_FLAGS", "find_chromium", "missing_browser", "open_page"]

#: Headless, no sandbox (CI runs as root), no GPU, and no background traffic (the machines have no network).
CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
    "--no-first-run", "--disable-sync", "--disable-quic",
)  # fmt: skip


def find_chromium() -> str | None:
    """The system's Chromium executable, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def missing_browser() -> str | None:
    """Why the page cannot be opened here (no Chromium, no playwright client), or None."""
    if find_chromium() is None:
        return "no Chromium installed (Debian: apt-get install -y chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the Python playwright client is not installed (it is in environment.lock)"
    return None


@contextmanager
def open_page(path, width: int = 1280, height: int = 800, timeout_ms: float = 60_000, metrics: bool = False):
    """Open the page ``path`` and wait until it has drawn its first orbit (``body[data-ready=true]``).

    Yields ``(page, log, url)``: the Playwright page, ``{"console": [(type, text)], "requests": [url]}``
    (page errors count as console messages of type ``"pageerror"``) and the page's ``file://`` URL. With
    ``metrics``, ``log["metrics"]`` holds Chromium's performance metrics when the page was ready
    (DevTools ``Performance.getMetrics``: ``ProcessTime`` and ``ThreadTime`` are the renderer's CPU seconds).
    """
    reason = missing_browser()
    if reason:
        raise RuntimeError(reason)
    from playwright.sync_api import sync_playwright

    url = Path(path).resolve().as_uri()
    with tempfile.TemporaryDirectory(prefix="nnmstop-chromium-") as profile, sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            profile, executable_path=find_chromium(), args=list(CHROMIUM_FLAGS), headless=True,
            viewport={"width": width, "height": height},
        )  # fmt: skip
        try:
            page = context.new_page()
            log = {"console": [], "requests": []}
            page.on("console", lambda message: log["console"].append((message.type, message.text)))
            page.on("pageerror", lambda error: log["console"].append(("pageerror", str(error))))
            page.on("request", lambda request: log["requests"].append(request.url))
            session = context.new_cdp_session(page) if metrics else None
            if session:
                session.send("Performance.enable", {"timeDomain": "threadTicks"})
            page.goto(url)
            page.wait_for_selector("body[data-ready=true]", timeout=timeout_ms)
            if session:
                log["metrics"] = {m["name"]: m["value"] for m in session.send("Performance.getMetrics")["metrics"]}
            yield page, log, url
        finally:
            context.close()

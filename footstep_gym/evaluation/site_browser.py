"""The site in a real browser: a local HTTP server on 127.0.0.1 and headless Chromium driven by selenium.

Used by ``make_site.py --screenshot`` (a PNG of the board page) and by the site's browser test. Needs Debian's
``chromium`` and ``chromium-driver`` (or any Chromium and its chromedriver on ``PATH``) and ``selenium``.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import shutil
import threading
from pathlib import Path
from typing import Any, Iterator

__all__ = ["browser_paths", "chrome", "screenshot", "serve", "SCREENSHOT_SIZE"]

#: The board's screenshot: 900 px wide (readable where the README shows it), tall enough for the board.
SCREENSHOT_SIZE = (900, 1400)


def browser_paths() -> tuple[str, str] | None:
    """``(chromium, chromedriver)`` found on ``PATH``, or None."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    driver = shutil.which("chromedriver")
    return (browser, driver) if browser and driver else None


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args: Any) -> None:  # the test reads the browser's log, not the server's
        pass


@contextlib.contextmanager
def serve(folder: Path) -> Iterator[str]:
    """Serve ``folder`` on 127.0.0.1 (a free port) in a thread; yields the base URL (``http://127.0.0.1:PORT/``)."""
    handler = functools.partial(_Quiet, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


@contextlib.contextmanager
def chrome(size: tuple[int, int] = SCREENSHOT_SIZE) -> Iterator[Any]:
    """Headless Chromium (selenium ``webdriver.Chrome``) with its console and network logged
    (``driver.get_log("browser")``, ``driver.get_log("performance")``); quit on exit."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    paths = browser_paths()
    if paths is None:
        raise FileNotFoundError("no chromium and chromedriver on PATH (Debian: apt-get install chromium chromium-driver)")
    options = webdriver.ChromeOptions()
    options.binary_location = paths[0]
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu", "--hide-scrollbars",
                f"--window-size={size[0]},{size[1]}", "--autoplay-policy=no-user-gesture-required",
                "--no-first-run", "--disable-background-networking", "--disable-component-update",
                "--disable-sync", "--disable-default-apps", "--force-device-scale-factor=1"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(executable_path=paths[1]))
    try:
        driver.set_window_size(*size)
        yield driver
    finally:
        driver.quit()


def screenshot(site: Path, png: Path, size: tuple[int, int] = SCREENSHOT_SIZE) -> Path:
    """A PNG of the site's board page (``index.html``), the browser window ``size`` [px]."""
    png.parent.mkdir(parents=True, exist_ok=True)
    with serve(site) as base, chrome(size) as driver:
        driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",  # the page's viewport exactly ``size``
                               {"width": size[0], "height": size[1], "deviceScaleFactor": 1, "mobile": False})
        driver.get(base + "index.html")
        driver.execute_script("return document.fonts ? document.fonts.ready : null")
        if not driver.save_screenshot(str(png)):
            raise RuntimeError(f"chromium wrote no screenshot to {png}")
    return png

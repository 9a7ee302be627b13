"""A real headless browser for the tests of HTML output: Chromium (Debian's `chromium`
package, installed by .ci/run) driven by Playwright. Without Chromium the tests that need it
are skipped on a developer's machine and fail under CI, so CI cannot pass without them."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

CANDIDATES = ("chromium", "chromium-browser", "google-chrome")


def chromium_path() -> str:
    found = os.environ.get("FLEXDYN_CHROMIUM") or next(filter(None, map(shutil.which, CANDIDATES)), None)
    if found:
        return found
    if os.environ.get("CI"):
        pytest.fail("Chromium is needed for the viewer tests: apt-get install chromium")
    pytest.skip("no Chromium on this machine (apt-get install chromium)")


class Page:
    """A page opened from a file, with every console message, page error and network request
    it made (file: URLs aside) recorded, and requests to the network refused."""

    def __init__(self, page):
        self.page, self.messages, self.requests = page, [], []
        page.on("console", lambda m: self.messages.append((m.type, m.text)))
        page.on("pageerror", lambda e: self.messages.append(("pageerror", str(e))))

        def refuse(route):
            if route.request.url.startswith("file:"):
                return route.continue_()
            self.requests.append(route.request.url)
            return route.abort()

        page.route("**/*", refuse)

    def errors(self) -> list:
        return [m for m in self.messages if m[0] in ("error", "pageerror")]

    def screenshot(self, path: Path) -> np.ndarray:
        from PIL import Image

        self.page.screenshot(path=str(path))
        return np.asarray(Image.open(path).convert("RGB"))


def open_page(path: Path, width=1000, height=700):
    """A context manager giving a `Page` with `path` loaded."""
    from contextlib import contextmanager

    from playwright.sync_api import sync_playwright

    exe = chromium_path()

    @contextmanager
    def run():
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=exe, args=["--enable-unsafe-swiftshader"])
            try:
                page = Page(browser.new_page(viewport={"width": width, "height": height}))
                page.page.goto(path.resolve().as_uri())
                yield page
            finally:
                browser.close()

    return run()

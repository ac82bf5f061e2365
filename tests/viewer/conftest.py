"""Fixtures of the viewer tests: a headless Chromium driven by Playwright.

The browser is the system's Chromium (``apt-get install chromium``; ``.ci/run`` installs it),
found at $TUMBLE_CHROMIUM, /usr/bin/chromium or on PATH. Browser tests skip when it or the
Playwright package is missing.
"""
import pytest

from tests.viewer.helpers import CHROMIUM_ARGS, chromium_path


@pytest.fixture(scope="module")
def browser():
    pytest.importorskip("viser")
    sync_api = pytest.importorskip("playwright.sync_api")
    exe = chromium_path()
    if exe is None:
        pytest.skip("no Chromium: apt-get install chromium (see .ci/run)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()

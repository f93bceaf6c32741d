"""
Fixtures of the viewer tests: a real headless Chromium driven by Playwright, real node processes.

The browser is Debian's ``chromium`` (``PX100_CHROMIUM`` to use another binary) launched by
Playwright for Python with ``executable_path``: nothing is downloaded. Where Playwright or the
browser is missing, the browser tests are skipped with the reason.
"""
import os
import shutil
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

CHROMIUM_ARGS = ['--no-sandbox', '--disable-gpu', '--use-gl=swiftshader',
                 '--enable-unsafe-swiftshader', '--no-first-run',
                 '--disable-background-networking', '--disable-component-update',
                 '--disable-sync', '--disable-dev-shm-usage']


def chromium_path() -> str:
    """Return the Chromium binary to drive, or '' if there is none."""
    env = os.environ.get('PX100_CHROMIUM')
    if env:
        return env if os.access(env, os.X_OK) else ''
    for name in ('chromium', 'chromium-browser', 'google-chrome'):
        path = shutil.which(name)
        if path:
            return path
    return ''


@pytest.fixture(scope='module')
def browser():
    """Yield a headless Chromium (Playwright); skip with the reason when there is none."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip('Playwright for Python is not installed (bash scripts/setup_browser.sh): '
                    'the viewer browser tests need it')
    path = chromium_path()
    if not path:
        pytest.skip('no Chromium browser found (apt install chromium, or set PX100_CHROMIUM; '
                    'bash scripts/setup_browser.sh): the viewer browser tests need one')
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=path, args=CHROMIUM_ARGS, headless=True)
        try:
            yield b
        finally:
            b.close()

"""
The page of ``pick_and_place_demo.py --viewer`` in a real browser, after the demo finished.

The demo (its own process, in-process nodes and viewer, the default scene) places the three
objects, prints its table and keeps the page up with the final scene (``--viewer-hold``); the
browser then reads the status panel: time since the start with its clock time, goals by number
(no epoch seconds), the default scene's 9 bodies, nothing held once released; the slider value
boxes show their whole numbers; the canvas shows the three objects in their colours. This page
is the README's screenshot (``PX100_UPDATE_DOCS_IMAGES=1`` writes docs/images/viewer.png, a
plain run out/images/viewer.png). Ctrl-C then ends the demo with its own exit status. Slow.
"""
import os
import re
import signal
import subprocess
import sys
import threading

import pytest
from viewer_support import colour_pixels, open_page, pixels, VIEWPORT, wait_canvas

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _read_until(proc, pattern: str, lines: list, timeout: float):
    """Return the first match of pattern in the process's output lines (None at timeout)."""
    found, done = [], threading.Event()

    def pump():
        for line in proc.stdout:
            lines.append(line)
            m = re.search(pattern, line)
            if m and not found:
                found.append(m)
                done.set()
        done.set()
    threading.Thread(target=pump, daemon=True).start()
    done.wait(timeout)
    return found[0] if found else None


#: the README's screenshot: the page at a desktop size
DOCS_VIEWPORT = {'width': 1000, 'height': 700}


def test_page_keeps_the_final_scene_in_readable_units(browser, tmp_path):
    """
    The demo's final page: readable status, whole slider values, the three placed objects.

    The page is VIEWPORT's size; with PX100_UPDATE_DOCS_IMAGES=1 1000x700 (the README's).
    """
    update_docs = os.environ.get('PX100_UPDATE_DOCS_IMAGES') == '1'
    viewport = DOCS_VIEWPORT if update_docs else VIEWPORT
    env = dict(os.environ, MPLBACKEND='Agg', PYTHONUNBUFFERED='1')
    proc = subprocess.Popen(
        [sys.executable, os.path.join(ROOT, 'scripts', 'pick_and_place_demo.py'), '--viewer',
         '--viewer-hold', '120', '--no-bag', '--no-plots',
         '--out', str(tmp_path)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    try:
        m = _read_until(proc, r'the final scene stays at (http://\S+):', lines, 300.0)
        assert m, ''.join(lines)[-4000:]
        assert any('placed 3/3 objects' in line for line in lines), ''.join(lines)[-3000:]
        page = open_page(browser, m.group(1), viewport=viewport)
        try:
            text = page.inner_text('body')
            state = re.search(r'state t = ([0-9.]+) s at (\d\d:\d\d:\d\d\.\d{3})', text)
            assert state and float(state.group(1)) > 5.0, text
            goal = re.search(r'trajectory: goal (\d+): SUCCEEDED', text)
            assert goal and 5 <= int(goal.group(1)) < 100, text
            assert not re.search(r'\d{9,}', text), text          # no epoch seconds anywhere
            assert 'world: 9 bodies' in text and 'holding: nothing' in text, text
            # every slider's value box shows its whole number (nothing scrolled out of view)
            boxes = page.evaluate(
                "() => [...document.querySelectorAll('input.mantine-NumberInput-input')]"
                '.map(e => [e.value, e.scrollWidth, e.clientWidth])')
            assert len(boxes) >= 4, boxes
            cut = [b for b in boxes if b[1] > b[2]]
            assert not cut, f'value boxes too narrow (value, text width, box width): {cut}'
            least = pixels(30, viewport)

            def objects_drawn(img):
                counts = {name: colour_pixels(img, rgb, 50) for name, rgb in (
                    ('red_cube', (217, 38, 38)), ('green_cube', (38, 178, 64)),
                    ('blue_cylinder', (38, 89, 217)))}
                return '; '.join(f'{name} not on the canvas ({n} <= {least} pixels)'
                                 for name, n in counts.items() if n <= least)
            wait_canvas(page, objects_drawn, 30.0)
            images = os.path.join(ROOT, 'docs' if update_docs else 'out', 'images')
            os.makedirs(images, exist_ok=True)
            page.screenshot(path=os.path.join(images, 'viewer.png'), timeout=90000)
        finally:
            page.close()
        assert proc.poll() is None, 'the demo ended before Ctrl-C'
        proc.send_signal(signal.SIGINT)
        assert proc.wait(60) == 0, ''.join(lines)[-3000:]
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            proc.wait(30)

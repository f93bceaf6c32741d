"""The README's client example runs as printed and really picks the red cube."""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def readme_example() -> str:
    """Return the first Python block of README.md."""
    with open(os.path.join(ROOT, 'README.md')) as f:
        return re.search(r'```python\n(.*?)```', f.read(), re.S).group(1)


def test_readme_client_example_picks_the_red_cube(tmp_path):
    """Run the example in its own process (in-process bringup): it ends holding 'red_cube'."""
    script = tmp_path / 'readme_example.py'
    script.write_text(readme_example())
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=240, cwd=str(tmp_path))
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().splitlines()[-1] == 'red_cube', (out.stdout[-2000:],
                                                               out.stderr[-2000:])

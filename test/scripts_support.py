"""Import one of the repository's scripts (scripts/*.py, not a package) to test its functions."""
import importlib.util
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load_script(name: str):
    """Return scripts/<name>.py imported as the module ``name`` (its main is not run)."""
    spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, 'scripts',
                                                                     f'{name}.py'))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

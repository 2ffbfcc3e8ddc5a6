"""Where the tests find the checkout: ROOT is the folder holding README.md and invrad_wb/,
found by walking up from here, so a test's own depth in tests/ (the folders mirror
invrad_wb's subpackages) never decides a path. tests/conftest.py puts tests/ on sys.path,
so every test imports this as ``from repo_paths import ROOT``."""
import os


def _root():
    d = os.path.dirname(os.path.abspath(__file__))
    while not (os.path.isfile(os.path.join(d, "README.md"))
               and os.path.isdir(os.path.join(d, "invrad_wb"))):
        up = os.path.dirname(d)
        if up == d:
            raise RuntimeError(f"no folder above {__file__} holds README.md and invrad_wb/")
        d = up
    return d


ROOT = _root()
TESTS = os.path.join(ROOT, "tests")
DATA = os.path.join(TESTS, "data")                  # sample files (FZK-Haus, photometry)
PHOTOMETRY = os.path.join(DATA, "photometry")
FZK_IFC = os.path.join(DATA, "AC20-FZK-Haus.ifc")
SCENE_FILE_HELPERS = os.path.join(TESTS, "core", "io")   # scene_file_helpers.py

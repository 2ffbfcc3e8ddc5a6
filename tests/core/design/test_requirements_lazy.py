"""classify_rooms on exact light (the command line's locate on every scene with --flux)
decides without the design modules: they are imported only for a work-plane level (the
requirement rooms themselves: tests/core/design/test_requirements.py)."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))))

DESIGN = ("invrad_wb.core.design.accent", "invrad_wb.core.design.evaluate",
          "invrad_wb.core.design.room", "invrad_wb.core.design.en12464")


def _imported_after_classify(path):
    code = ("import sys; from invrad_wb.core.io.sceneio import read_scene;"
            "from invrad_wb.core.design.requirements import classify_rooms;"
            f"k = classify_rooms(read_scene({path!r}));"
            "print(sorted(k.items())[0][1].kind);"
            f"print(' '.join(m for m in {DESIGN!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.splitlines()
    return out[0], out[1].split() if len(out) > 1 else []


def test_exact_light_imports_no_design_module():
    kind, mods = _imported_after_classify(os.path.join(ROOT, "examples", "office.ply"))
    assert kind == "exact"
    assert mods == []


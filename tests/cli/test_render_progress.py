"""Render reports its progress (luminaire pairs done: direct light, then the patches of the
interreflection), the light is the same with or without it (luminaires in blocks), and a
False from the callback cancels."""
import numpy as np
import pytest

from invrad_wb.core.forward import direct as D
from invrad_wb.core.forward.render import render
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.synthetic import generate as g
from invrad_wb.errors import Cancelled


def _setup():
    scene, _ = g.floor_of_rooms(rooms=((3.0, 3.0), (2.0, 3.0)), cell=0.5)
    rng = np.random.default_rng(2)
    lums = [Luminaire([rng.uniform(0.2, 5.0), rng.uniform(0.2, 2.8), 2.9], [0, 0, -1],
                      500.0) for _ in range(9)]
    for lum in lums:
        lum.room = 0 if lum.position[0] < 3.0 else 1
        lum.position[0] += 0.2 * lum.room               # past the wall
    return scene, lums


def test_progress_rises_to_one_and_the_light_is_the_same(monkeypatch):
    scene, lums = _setup()
    want = render(scene, lums, backend="numpy")
    monkeypatch.setattr(D, "PROGRESS_PAIRS", 3 * len(scene.vertices))   # blocks of 3
    seen = []
    got = render(scene, lums, backend="numpy",
                 progress=lambda f, msg: seen.append((f, msg)) or True)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    fr = [f for f, _ in seen]
    assert fr[-1] == 1.0 and all(b >= a for a, b in zip(fr, fr[1:]))
    assert len(set(fr)) > 4                     # steps in between, not just 0 and 1
    msgs = [m for _, m in seen]
    assert any(m.startswith("direct light of 9 luminaire(s)") for m in msgs)
    assert any(m == "interreflection" for m in msgs)


def test_false_cancels():
    scene, lums = _setup()
    with pytest.raises(Cancelled):
        render(scene, lums, backend="numpy", progress=lambda f, msg: f < 0.3)


def test_a_floor_of_many_rooms_is_announced_with_its_size():
    from invrad_wb.progress import FLOOR_NOTE_ROOMS, floor_note
    many, _ = g.floor_of_rooms(rooms=((2.0, 2.0),) * FLOOR_NOTE_ROOMS, cell=1.0)
    note = floor_note(many, 2)
    assert note.startswith(f"{FLOOR_NOTE_ROOMS} rooms x ") and f"({len(many.faces)} faces)"\
        in note and "2 at a time" in note
    assert "--workers N" in floor_note(many, 1)
    few, _ = g.floor_of_rooms(rooms=((2.0, 2.0),) * (FLOOR_NOTE_ROOMS - 1), cell=1.0)
    assert floor_note(few, 1) is None

"""A luminaire lights only its own room: rooms that touch without a wall between them
(FZK-Haus: Kueche and Wohnen) do not take each other's light on their shared border."""
import numpy as np

from invrad_wb.core.forward.render import render
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.synthetic import generate as g


def _two_touching_rooms():
    return g.floor_of_rooms(((3.0, 3.0), (3.0, 3.0)), height=2.5, wall=0.0, cell=0.25)


def test_no_light_across_an_open_border():
    scene, origins = _two_touching_rooms()
    border = origins[1][0]
    lum = Luminaire([border - 0.3, 1.5, 2.5], [0, 0, -1], 3000.0, room=0)
    got = render(scene, [lum], interreflection=False, backend="numpy")
    vr = np.full(len(scene.vertices), -1)
    vr[scene.faces.reshape(-1)] = np.repeat(scene.face_room, 3)
    other = vr == 1
    on_border = other & (np.abs(scene.vertices[:, 0] - border) < 1e-9)
    assert on_border.sum() > 10
    assert np.all(got[other] == 0.0)
    # before: the border's vertices in room 1 took room 0's light (no face in between)
    free = Luminaire(lum.position, lum.normal, lum.flux_lm)          # no room
    old = render(scene, [free], interreflection=False, backend="numpy")
    assert old[on_border].max() > 100.0
    np.testing.assert_array_equal(got[vr == 0], old[vr == 0])        # its own room: same


def test_one_room_and_roomless_luminaires_are_unchanged():
    s = g.box_room((4, 3, 2.5), cell=0.3)
    lums = [Luminaire([2.0, 1.5, 2.5], [0, 0, -1], 2000.0, room=0),
            Luminaire([1.0, 1.0, 2.5], [0, 0, -1], 1000.0)]
    a = render(s, lums, interreflection=False, backend="numpy")
    b = render(s, [Luminaire(l.position, l.normal, l.flux_lm) for l in lums],
               interreflection=False, backend="numpy")
    np.testing.assert_array_equal(a, b)

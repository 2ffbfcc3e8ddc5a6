"""UGR rates the installation new (CIE 117; EN 12464-1's limits hold in new condition):
the luminaires' luminance and the background luminance both without the maintenance
factor, so a room's UGR does not depend on it (until round 12 the background was taken
maintained, which read every room 8 log10(1 / MF) high)."""
import numpy as np
import pytest

from invrad_wb.core.design.evaluate import RoomModel
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.roomglare import glare_terms, room_ugr
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.output.glare import observers, ugr, ugr_from_sum
from invrad_wb.core.synthetic import generate as g


def test_room_ugr_is_the_new_installations_and_its_terms_add_up():
    sc = g.with_reflectances(g.box_room(size=(5.0, 4.0, 2.8), cell=0.4))
    droom = DesignRoom(sc, 0)
    lums = [Luminaire(position=np.array([x, y, 2.78]), normal=np.array([0.0, 0.0, -1.0]),
                      flux_lm=3000.0, radius_m=0.3)
            for x in (1.25, 3.75) for y in (1.0, 3.0)]
    pts = droom.grid(0.8, 0.5)[0]
    u = {mf: room_ugr(RoomModel(sc, droom, pts, mf, backend="numpy"), droom, lums)
         for mf in (0.5, 0.8, 1.0)}
    assert u[0.5] == pytest.approx(u[1.0], abs=1e-9) == pytest.approx(u[0.8], abs=1e-9)
    # the same figure from the formula with the unmaintained interreflected light at the
    # eyes (an MF in the background would move it by 8 log10(1 / 0.8) = 0.78)
    model = RoomModel(sc, droom, pts, 0.8, backend="numpy")
    obs = observers(droom)
    eyes, views = np.array([e for e, _ in obs]), np.array([v for _, v in obs])
    lb = model.indirect_at(eyes, views, lums)
    assert lb.min() > 10.0
    by_hand = max(x for x in (ugr(lums, e, v, b) for (e, v), b in zip(obs, lb))
                  if x is not None)
    assert u[0.8] == pytest.approx(by_hand, abs=1e-9)
    # glare_terms gives the parts the design's programme adds up (the whole's openings
    # in place), on the same footing
    t1, b1 = glare_terms(model, droom, lums[:2], covering=lums)
    t2, b2 = glare_terms(model, droom, lums[2:], covering=lums)
    assert np.nanmax(ugr_from_sum(t1 + t2, b1 + b2)) == pytest.approx(u[0.8], abs=1e-6)

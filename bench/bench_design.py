"""Design from requirements against the lighting designer's best regular grid (figures only).

For six rooms of different shapes and requirements (office, classroom, corridor, bathroom,
L-shaped open plan, high workshop; reflectances 0.7/0.5/0.2, interreflection on), in one run:

* **grid**: the reference: every catalogue entry, every ns x nt ceiling grid with half
  spacing at the walls, no dimming; the compliant one of least watts (exact model);
* **invrad**: ``design()`` with the same catalogue (free edge distances, two entries per
  layout), no dimming;
* **invrad+dim**: the same catalogue made dimmable (10-100 %).

Prints per room the watts, Em, U0, the walls' and the ceiling's Em / U0, verdict and
seconds, and the totals. Compliance of both is recomputed here independently of the search
(a fresh exact solve of the chosen luminaires on the room's EN 12464-1 grids: the work
plane, and the walls and ceiling held to the EN 12464-1:2021 5.2.3 minimums, which the
grid reference is judged on too).
"""
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from invrad_wb.core.design.design import design_room  # noqa: E402
from invrad_wb.core.design.evaluate import RoomModel, surface_grids  # noqa: E402
from invrad_wb.core.design.room import DesignRoom  # noqa: E402
from invrad_wb.core.design.search import (Metrics, RoomSearch,  # noqa: E402
                                          best_regular_grid)
from invrad_wb.core.design.spec import spec_from_dict  # noqa: E402
from invrad_wb.core.synthetic.design_rooms import ROOMS, spec_dict  # noqa: E402


def room_model(scene, spec):
    """Room 0's spec, :class:`DesignRoom` and exact :class:`RoomModel` (the work plane's
    calculation grid, walls and ceiling), as the design engine builds them."""
    rs = spec.room_spec(0)
    droom = DesignRoom(scene, 0)
    pts, _ = droom.grid(rs.work_plane.height_m, rs.work_plane.margin_m)
    model = RoomModel(scene, droom, pts, spec.maintenance_factor,
                      surfaces=surface_grids(scene, 0, droom))
    return rs, droom, model


def independent_check(scene, spec, lums):
    """Metrics of luminaires by a fresh exact solve (no state shared with the search) and
    the verdict on the work plane, walls and ceiling."""
    rs, _, model = room_model(scene, spec)
    lux, direct = model.exact(lums)
    met = Metrics.of(lux, direct, model.layout)
    ok = (met.em >= rs.work_plane.lux - 1e-6 and met.u0 >= rs.work_plane.u0 - 1e-6
          and all(met.surface_ok(rs.surfaces).values()))
    return met, ok


def grid_reference(scene, spec):
    rs, droom, model = room_model(scene, spec)
    search = RoomSearch(model, rs.work_plane, rs,
                        spec.entries_for(rs, droom.top_z - droom.floor_z), mixed=False,
                        dimming=False, fractions=(0.5,))
    best = best_regular_grid(search)
    if best is None:
        return None, []
    return best[0], search.luminaires(best[0])


def main():
    rows = []
    print(f"{'room':10s} {'method':11s} {'W':>8s} {'Em lx':>7s} {'U0':>5s} {'walls':>10s}"
          f" {'ceiling':>10s} {'ok':>3s} {'s':>6s}  layout")
    for name, (build, req) in ROOMS.items():
        scene = build()
        spec = spec_from_dict(spec_dict(name))
        spec_dim = spec_from_dict(spec_dict(name, dimming=(0.1, 1.0)))
        t = time.perf_counter()
        ref, ref_lums = grid_reference(scene, spec)
        t_ref = time.perf_counter() - t
        out = {"grid": (ref.watts if ref else np.inf, ref_lums, t_ref,
                        ref.geom.describe() + f" of {ref_lums[0].extra['type']}" if ref
                        else "none complies")}
        for label, sp, kw in (("invrad", spec, {"dimming": False}),
                              ("invrad+dim", spec_dim, {})):
            t = time.perf_counter()
            rd = design_room(scene, sp, 0, **kw)
            dt = time.perf_counter() - t
            types = ", ".join(f"{n} x {k}" for k, n in sorted(rd.schedule().items()))
            out[label] = (rd.watts, rd.luminaires, dt, f"{rd.candidate.geom.describe()}:"
                          f" {types}" + (f" at {100 * rd.candidate.dim:.0f} %"
                                         if rd.candidate.dim < 1 else ""))
        for label, (w, lums, dt, desc) in out.items():
            if lums:
                met, ok = independent_check(scene, spec, lums)
                em, u0 = met.em, met.u0
                wl, cl = (f"{met.surfaces[k][0]:.0f}/{met.surfaces[k][2]:.2f}"
                          for k in ("walls", "ceiling"))
            else:
                em, u0, wl, cl, ok = 0.0, 0.0, "-", "-", False
            rows.append((name, label, w, ok, dt))
            print(f"{name:10s} {label:11s} {w:8.1f} {em:7.1f} {u0:5.2f} {wl:>10s} {cl:>10s}"
                  f" {'yes' if ok else 'NO':>3s} {dt:6.2f}  {desc}")
    print()
    for label in ("grid", "invrad", "invrad+dim"):
        sel = [r for r in rows if r[1] == label]
        total = sum(r[2] for r in sel)
        print(f"{label:11s} total {total:8.1f} W, compliant {sum(r[3] for r in sel)}/{len(sel)},"
              f" max {max(r[4] for r in sel):.2f} s per room")
    g = {r[0]: r[2] for r in rows if r[1] == "grid"}
    for label in ("invrad", "invrad+dim"):
        w = {r[0]: r[2] for r in rows if r[1] == label}
        worse = [k for k in w if w[k] > g[k] + 1e-6]
        saving = 100.0 * (1.0 - sum(w.values()) / sum(g.values()))
        print(f"{label}: {saving:.1f} % fewer watts than the grids in total;"
              f" rooms using more than the grid: {worse or 'none'}")


if __name__ == "__main__":
    main()

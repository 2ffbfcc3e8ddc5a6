"""Time of the task areas' grids in a large open-plan room (taskareas.py): a 30 x 20 m
room with 28 desks (4 rows of 7, 1.6 x 0.8 m) and a counter: each area's cells, the
immediate surroundings and the background (CPU seconds, best of ``--repeat``).

    python bench/bench_taskarea_bands.py [--repeat 3]
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from invrad_wb.core.design.room import DesignRoom  # noqa: E402
from invrad_wb.core.design.spec import spec_from_dict  # noqa: E402
from invrad_wb.core.design import taskareas as T  # noqa: E402
from invrad_wb.core.synthetic import generate as g  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    desks = [{"name": f"desk {i * 7 + j + 1}",
              "rect": [3 + 3.5 * j, 3 + 4 * i, 4.6 + 3.5 * j, 3.8 + 4 * i]}
             for i in range(4) for j in range(7)]
    areas = desks + [{"name": "counter", "rect": [26, 17, 29, 18], "lux": 300}]
    spec = spec_from_dict({"catalogue": [{"name": "DL", "flux_lm": 3500, "watts": 26}],
                           "rooms": {"0": {"work_plane": {"lux": 500, "u0": 0.6,
                                                          "task_areas": areas}}}},
                          source="bench")
    wp = spec.room_spec(0).work_plane
    dr = DesignRoom(g.box_room(size=(30.0, 20.0, 3.0), cell=2.0), 0)
    for what, f in (("surroundings", lambda: T.band_cells(
                        dr, 0.75, wp.task_areas, 0.0, T.SURROUNDINGS_M, T.BAND_SPACING_M)),
                    ("background", lambda: T.band_cells(
                        dr, 0.75, wp.task_areas, T.SURROUNDINGS_M,
                        T.SURROUNDINGS_M + T.BACKGROUND_M, 0.5 * T.BACKGROUND_M))):
        best = float("inf")
        for _ in range(args.repeat):
            t0 = time.process_time()
            out = f()
            best = min(best, time.process_time() - t0)
        print(f"{what}: {len(out[0])} cells, {out[2].sum():.2f} m2, {best:.2f} CPU s")


if __name__ == "__main__":
    main()

"""How a candidate layout describes itself to the architect: the rows and columns it keeps."""
import numpy as np

from invrad_wb.core.design.layouts import Geometry, axis_positions


def _grid(ns, nt, f, size, keep):
    s, t = axis_positions(size[0], ns, (f, f)), axis_positions(size[1], nt, (f, f))
    plan = np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2)
    ok = keep(plan)
    n = int(ok.sum())
    return Geometry(ns, nt, (f, f), (f, f), plan[ok], np.zeros((n, 3)), np.zeros((n, 3)),
                    np.zeros(n, int), size=size)


def test_a_grid_whose_outer_rows_fall_too_close_to_the_walls_says_what_is_left():
    # 5 x 4 positions at 0.35 of the spacing from the walls of a 6 x 4 m room: the outer
    # ones are 0.45 / 0.38 m from the walls and dropped; six remain, 3 x 2
    g = _grid(5, 4, 0.35, (6.0, 4.0), lambda p: (np.minimum(p, (6.0, 4.0) - p) > 0.45).all(1))
    assert g.count == 6
    words = g.describe()
    assert words.startswith("3 x 2 grid")
    assert "1.28 m apart, 1.72 m from the walls" in words       # along: 6 / 4.7 spacing
    assert "1.08 m apart, 1.46 m from the walls" in words       # across: 4 / 3.7


def test_a_full_grid_gives_its_spacing_and_an_l_its_clipped_count():
    g = _grid(3, 2, 0.5, (6.0, 4.0), lambda p: np.ones(len(p), bool))
    assert g.describe() == ("3 x 2 grid: along the room 2.00 m apart, 1.00 m from the walls;"
                            " across 2.00 m apart, 1.00 m from the walls")
    ell = _grid(3, 3, 0.5, (6.0, 6.0), lambda p: ~((p[:, 0] > 3) & (p[:, 1] > 3)))
    assert ell.describe() == ("8 positions of a 3 x 3 grid (the others fall outside the"
                              " room's outline or in an obstacle, or the design left them"
                              " out)")
    # a column left out over a stair: not a regular 4 x 2 grid
    hole = _grid(5, 2, 0.5, (7.0, 5.0), lambda p: np.abs(p[:, 0] - 3.5) > 0.1)
    assert hole.describe().startswith("8 positions of a 5 x 2 grid (the others")

"""A report of many luminaires stays readable: figures label luminaires one by one only
up to MAX_LABELLED (1000 labelled luminaires took 44 s to draw and covered the light).
The table's cap (report.MAX_TABLE_LUMINAIRES) is measured by bench/probe_faults.py's
'verify 10,000 luminaires' (a report end to end is too slow for the suite)."""
import numpy as np

from invrad_wb.core.output import figures as F


def test_many_luminaires_are_marked_without_labels():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots()
    try:
        xy = np.random.default_rng(0).uniform(0, 5, size=(F.MAX_LABELLED + 1, 2))
        F.luminaire_marks(ax, xy, [f"L{i + 1}" for i in range(len(xy))])
        assert len(ax.texts) == 0 and len(ax.lines) == 2
        ax.clear()
        F.luminaire_marks(ax, xy[:3], ["L1", "L2", "L3"])
        assert [t.get_text() for t in ax.texts] == ["L1", "L2", "L3"]
    finally:
        plt.close(fig)



def _marks_one_by_one(view, lay, max_dist=0.35):
    """The definition of unfolded_marks, luminaire by luminaire and plane by plane."""
    s = view.scene
    xy, labels = [], []
    for pos, lab in zip(view.lum_xyz, view.lum_labels):
        best = None
        for k, (A, b) in lay.tiles.items():
            p = s.planes[k]
            if p.is_virtual:
                continue
            d = float(p.signed_distance(pos[None])[0])
            if -0.01 <= d <= max_dist and (best is None or d < best[0]):
                foot = pos - d * p.normal
                uv = p.to_plane_coords(foot[None])[0]
                if np.all(uv >= -1e-6) and np.all(uv <= p.size + 1e-6):
                    best = (d, A @ foot + b)
        if best is not None:
            xy.append(best[1])
            labels.append(lab)
    return np.array(xy).reshape(-1, 2), labels


def test_unfolded_marks_at_the_foot_on_the_nearest_plane():
    """Ceiling, wall and corner luminaires are marked at their foot point on the nearest
    real plane (as a per-luminaire loop defines it); one hanging mid-room is not marked."""
    from invrad_wb.core.output import room_figures as RF
    from invrad_wb.core.synthetic import generate as g
    scene = g.box_room(size=(6.0, 4.0, 3.0), cell=0.5)
    rng = np.random.default_rng(1)
    pos = np.concatenate([
        np.c_[rng.uniform(0.2, 5.8, 300), rng.uniform(0.2, 3.8, 300), np.full(300, 2.95)],
        [[0.05, 2.0, 2.0], [3.0, 3.9, 1.5], [0.1, 0.2, 2.9], [3.0, 2.0, 1.5],
         [3.0, 2.0, 3.005]]])
    nv = len(scene.vertices)
    view = RF.RoomView(scene, 0, "box", np.full(nv, 100.0), np.full(nv, 100.0),
                       np.zeros(nv), 200.0, 0.5, pos, [f"L{i + 1}" for i in range(len(pos))])
    lay = view.unfolded()
    xy, labels = RF.unfolded_marks(view, lay)
    ref_xy, ref_labels = _marks_one_by_one(view, lay)
    assert labels == ref_labels
    np.testing.assert_allclose(xy, ref_xy, atol=1e-12)
    assert f"L{len(pos) - 1}" not in labels          # mid-room: on no plane
    assert len(labels) == len(pos) - 1

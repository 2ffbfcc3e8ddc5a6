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


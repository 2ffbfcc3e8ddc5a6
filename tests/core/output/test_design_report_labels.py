"""Iso-lux labels of the design report's plans keep off the luminaires' markers as drawn:
a room dimmed apart has its group letters written in the markers, which makes them two
to three times the plain marker's size. FZK-Haus' Galerie (11 luminaires on two rows)
had its '400 lx' label half under a lettered marker. Made-up designs (no search): fast."""
import numpy as np
import pytest

from invrad_wb.core.output import design_report as D

from test_design_report_groups import CAT, _room


def _gallery(rows_y, xs, size, outputs):
    pos = np.array([(x, y) for y in rows_y for x in xs])
    rd = _room(pos, outputs, size=size)
    w, h = size
    gx, gy = np.meshgrid(np.linspace(1.2, w - 1.2, 14), np.linspace(2.2, h - 1.6, 12))
    pts = np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, 0.75)]
    # pools of light under the luminaires, as a sloped ceiling's downlights give them
    d2 = np.sum((pts[:, None, :2] - pos[None]) ** 2, axis=2)
    lux = 60.0 + (600.0 * np.asarray(outputs)[None] * np.exp(-d2 / 1.5)).sum(axis=1)
    rd.grid_points = pts
    rd.metrics.lux, rd.metrics.em = lux, float(lux.mean())
    rd.metrics.u0, rd.metrics.emin = float(lux.min() / lux.mean()), float(lux.min())
    return rd, pos


def _marker_boxes(ax):
    """Each luminaire marker's box on the page (display pixels), from its drawn size."""
    px = ax.figure.dpi / 72.0
    out = []
    for line in ax.get_lines():
        if line.get_gid() != "luminaires":
            continue
        half = 0.5 * (line.get_markersize() + line.get_markeredgewidth()) * px
        for c in ax.transData.transform(np.column_stack(line.get_data())):
            out.append((c[0] - half, c[1] - half, c[0] + half, c[1] + half))
    return np.array(out).reshape(-1, 4)


@pytest.mark.parametrize("outputs", [
    # the Galerie's groups: 92 % in the middle, 53 % at the ends, 16 % between
    [0.53, 0.16, 0.92, 0.92, 0.16, 0.53] * 2,
    [1.0, 0.6, 0.3, 0.3, 0.6, 1.0] * 2])
def test_iso_lux_labels_keep_off_lettered_markers(outputs):
    rd, pos = _gallery((2.65, 7.35), (1.25, 3.15, 5.05, 6.95, 8.85, 10.75), (11.4, 9.4),
                       outputs)
    # the report's fourth type: drawn as a triangle, the marker that needs the most room
    # around its letter
    types = ["DL-600", "DL-1000", "DL-2000", "DL-3500"]
    fig = D.room_plan_figure(rd, rd.outline, 700.0, types, D.output_groups(rd, CAT))
    fig.canvas.draw()
    ax = fig.axes[0]
    assert [t for t in ax.texts if t.get_gid() == "group-label"]     # lettered markers
    renderer = fig.canvas.get_renderer()
    labels = [t for t in ax.texts if t.get_text().endswith(" lx")]
    assert labels
    boxes = np.array([t.get_window_extent(renderer).extents for t in labels])
    marks = _marker_boxes(ax)
    overlap = ((boxes[:, None, 0] < marks[None, :, 2]) & (marks[None, :, 0] < boxes[:, None, 2])
               & (boxes[:, None, 1] < marks[None, :, 3]) & (marks[None, :, 1] < boxes[:, None, 3]))
    assert not overlap.any(), [labels[i].get_text() for i in np.where(overlap.any(axis=1))[0]]

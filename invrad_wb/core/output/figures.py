"""Matplotlib building blocks shared by the verification and the design report.

Figures are drawn on an Agg canvas without pyplot (no global state, safe in worker
threads and inside FreeCAD), sized for an A4 page's text width (:data:`PAGE_WIDTH_IN`) so
that their fonts print at their nominal size, and returned as PNG bytes.

Colour scales (one per quantity, the same in every report and in the workbench):

* illuminance: viridis, linear from 0 to a round top (:func:`invrad_wb.core.output.images.
  nice_max`); values above the top get the top colour (the colour bar's arrow says so);
* deviation from the target: blue (too dark) - white (on target) - red (too bright),
  ``+-limit`` at the ends, in per cent;
* no target: light grey; a shade target (0 lx, "must stay dark"): black.
"""
import io

import numpy as np

#: text width of an A4 page with 15 mm margins (inches): figures are drawn at this width
PAGE_WIDTH_IN = 7.1
#: resolution of the PNGs (dots per inch): sharp on paper, ~1070 px across
DPI = 150
#: colour of "no target" areas
NO_TARGET = "#d9d9d9"
#: colour of shade targets in target views
SHADE = "#050505"
#: iso-lux line colour
ISO_COLOUR = "white"


def figure(width_in, height_in, dpi=DPI):
    """A matplotlib Figure on its own Agg canvas (no pyplot state)."""
    from matplotlib.figure import Figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = Figure(figsize=(width_in, height_in), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def png(fig):
    """PNG bytes of a figure, cropped to what is drawn."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight", pad_inches=0.04)
    return buf.getvalue()


def lux_norm(vmax, vmin=0.0):
    from matplotlib.colors import Normalize
    return Normalize(vmin=vmin, vmax=vmax, clip=False)


def lux_cmap():
    """viridis, top colour above the scale."""
    import matplotlib
    cmap = matplotlib.colormaps["viridis"].copy()
    cmap.set_over(cmap(1.0))
    cmap.set_bad(NO_TARGET)
    return cmap


def deviation_cmap():
    """Blue - white - red (RdBu reversed), end colours beyond the limit."""
    import matplotlib
    from invrad_wb.core.output.images import DIVERGING_CMAP
    cmap = matplotlib.colormaps[DIVERGING_CMAP].copy()
    cmap.set_bad(NO_TARGET)
    return cmap


def iso_levels(values, required=None, max_lines=5):
    """Round iso-lux levels inside the range of the values (about ``max_lines`` of them),
    ``required`` among them when it lies inside.

    Parameters
    ----------
    values : (k,) float64, lux (NaN ignored)
    required : float or None, lux

    Returns
    -------
    sorted list of float
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if not len(v):
        return []
    lo, hi = float(np.min(v)), float(np.max(v))
    if hi - lo < 1e-6:
        return []
    steps = (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 5000)
    step = next((s for s in steps if (hi - lo) / s <= max_lines), 10000)
    levels = set(np.arange(np.ceil(lo / step) * step, hi, step).tolist())
    levels.discard(lo)
    if required is not None and np.isfinite(required) and lo < required < hi:
        levels = {x for x in levels if abs(x - required) > 0.3 * step}
        levels.add(float(required))
    return sorted(levels)


def boundary_edges(faces):
    """Edges used by exactly one of the triangles ``faces`` (k, 3) (vertex index pairs
    (m, 2)): the outline of a face set."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if not len(f):
        return np.zeros((0, 2), np.int64)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    u, count = np.unique(e, axis=0, return_counts=True)
    return u[count == 1]


def draw_segments(ax, xy_pairs, **kw):
    """Line segments (m, 2, 2) metres as one LineCollection."""
    from matplotlib.collections import LineCollection
    if len(xy_pairs):
        ax.add_collection(LineCollection(np.asarray(xy_pairs), **kw))


#: luminaires in a figure above which they are not labelled one by one (the labels would
#: cover each other and the light; matplotlib drew 1000 labelled luminaires in 44 s)
MAX_LABELLED = 60


def luminaire_marks(ax, xy, labels=None, size=8.0):
    """Luminaires as white rings with a black dot, labelled ("L1") beside them (up to
    :data:`MAX_LABELLED` of them; more are drawn smaller and unlabelled)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if not len(xy):
        return
    if len(xy) > MAX_LABELLED:
        labels = None
        size = min(size, 4.0)
    ax.plot(xy[:, 0], xy[:, 1], "o", ms=size, mfc="white", mec="black", mew=1.3, zorder=6)
    ax.plot(xy[:, 0], xy[:, 1], ".", ms=2.5, color="black", zorder=7)
    for (x, y), t in zip(xy, labels or []):
        ax.annotate(t, (x, y), xytext=(5, 4), textcoords="offset points", fontsize=7.5,
                    zorder=8, bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none",
                                        alpha=0.85))


def scale_bar(ax, metres, fontsize=8):
    """A labelled length bar in the lower left corner (matplotlib's AnchoredSizeBar)."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar
    ax.add_artist(AnchoredSizeBar(ax.transData, metres, f"{metres:g} m", "lower left",
                                  pad=0.2, borderpad=0.3, frameon=False, size_vertical=0,
                                  fontproperties={"size": fontsize}))


def round_length(span):
    """A round scale-bar length (1, 2, 5 x 10^k m), the largest at most a fifth of
    ``span`` metres."""
    best = 0.1
    for s in (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0):
        if s <= span / 5:
            best = s
    return best

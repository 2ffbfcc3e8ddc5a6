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
import math

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


#: iso-lux labels are kept this far apart on the page (points): a clear gap, not touching
ISO_LABEL_GAP_PT = 2.0
#: a luminaire marker's half size on the plans (points): labels keep off it
MARKER_HALF_PT = 5.0


#: where along an iso-lux line a label is tried, in order (shares of its length): from
#: the middle outwards in steps of 0.05 (a line between luminaire markers finds its gap)
LABEL_AT = tuple(sorted(np.round(np.arange(0.1, 0.91, 0.05), 2).tolist(),
                        key=lambda f: (abs(f - 0.5), f)))


def _candidates(ax, cs, values, label_px):
    """Places for iso-lux labels: per line (a path of the contour set, in display
    pixels) at least as long as its label, the points :data:`LABEL_AT` along it. Returns
    (line index, value, xy data, angle) tuples, each line's in that order."""
    out = []
    to_data = ax.transData.inverted()
    line = 0
    # allsegs (per level, its lines' vertices) is in every matplotlib since 3.x; the
    # per-level ``collections`` were removed in 3.10 (a ContourSet is one Collection now)
    for segs, v in zip(cs.allsegs, values):
        w = label_px(v)[0]
        for seg in segs:
            xy = ax.transData.transform(seg)
            if len(xy) < 2:
                continue
            seg = np.linalg.norm(np.diff(xy, axis=0), axis=1)
            s = np.r_[0.0, np.cumsum(seg)]
            if s[-1] < w:        # shorter than the label: it would hide the line
                continue
            for f in LABEL_AT:
                k = int(np.clip(np.searchsorted(s, f * s[-1]), 1, len(xy) - 1))
                d = xy[k] - xy[k - 1]
                out.append((line, v, to_data.transform(xy[k]), xy[k],
                            float(np.arctan2(d[1], d[0]))))
            line += 1
    return out


def label_iso_lines(ax, cs, required=None, avoid=None, fontsize=7, inline_spacing=3,
                    field=None, avoid_half_pt=None):
    """Label the iso-lux lines ``cs`` (a contour set of ``ax``) where each label fits:
    candidate places along each line at least as long as its label (:data:`LABEL_AT`:
    halfway first), kept one by one (the required level's lines first) only where the label's box (turned along the
    line, padded by :data:`ISO_LABEL_GAP_PT`) overlaps no label kept before, no plan point
    of ``avoid`` ((k, 2) data coordinates: the luminaires' markers) and stays inside the
    axes and, where ``field`` (a matplotlib Triangulation) is given, on the coloured field
    (white on the white page beside it is unreadable; ``avoid_half_pt``: the markers'
    half size as drawn, points, else :data:`MARKER_HALF_PT`); one label per line, at its first place that fits. The kept ones are drawn inline
    (the line broken under them only). Matplotlib's own ``clabel`` measures the lines
    where it is called and never looks at the other labels: called before the page's
    layout shrank the panel, a small task area with steep light got four labels on top
    of each other. Call this once the layout is final. Returns the label texts."""
    fmt = lambda x: f"{x:.0f} lx"         # noqa: E731
    values = [float(v) for v in cs.levels]
    fig = ax.figure
    ax.apply_aspect()
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    sizes = {}

    def label_px(v):
        if v not in sizes:
            t = ax.text(0, 0, fmt(v), fontsize=fontsize)
            e = t.get_window_extent(renderer)
            t.remove()
            sizes[v] = (e.width + 2 * inline_spacing, e.height)
        return sizes[v]

    cands = _candidates(ax, cs, values, label_px)
    if not cands:
        return []
    pad = ISO_LABEL_GAP_PT * px / 2
    boxes = []
    for _, v, _, c, a in cands:
        w, h = label_px(v)
        hw = 0.5 * (w * abs(math.cos(a)) + h * abs(math.sin(a))) + pad
        hh = 0.5 * (w * abs(math.sin(a)) + h * abs(math.cos(a))) + pad
        boxes.append((c[0] - hw, c[1] - hh, c[0] + hw, c[1] + hh))
    boxes = np.array(boxes)
    frame = ax.get_window_extent(renderer).extents
    first = [0 if required is not None and abs(v - required) < 1e-6 else 1
             for _, v, *_ in cands]
    order = sorted(range(len(cands)), key=lambda i: first[i])     # stable: along a line
    marks = np.zeros((0, 4))
    if avoid is not None and len(avoid):
        c = ax.transData.transform(np.asarray(avoid, dtype=float)[:, :2])
        h = (MARKER_HALF_PT if avoid_half_pt is None else avoid_half_pt) * px
        marks = np.c_[c - h, c + h]

    def hits(b, others):
        return bool(len(others)) and bool(np.any(
            (b[0] < others[:, 2]) & (others[:, 0] < b[2])
            & (b[1] < others[:, 3]) & (others[:, 1] < b[3])))

    finder = None
    if field is not None:
        try:
            finder = field.get_trifinder()
        except (RuntimeError, ValueError):   # a mesh's triangles that overlap: no check
            finder = None
    to_data = ax.transData.inverted()

    def on_field(b):
        if finder is None:
            return True
        # the padded box's corners and edge middles (the label as drawn turns by
        # matplotlib's own angle, a little off the estimate)
        xm, ym = 0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3])
        c = to_data.transform([[b[0], b[1]], [b[2], b[1]], [b[0], b[3]], [b[2], b[3]],
                               [xm, b[1]], [xm, b[3]], [b[0], ym], [b[2], ym]])
        return bool(np.all(finder(c[:, 0], c[:, 1]) >= 0))

    kept, done = [], set()
    for i in order:
        if cands[i][0] in done:          # one label per line
            continue
        b = boxes[i]
        inside = (b[0] >= frame[0] and b[1] >= frame[1] and b[2] <= frame[2]
                  and b[3] <= frame[3])
        if (inside and not hits(b, marks) and not hits(b, boxes[kept])
                and on_field(b)):
            kept.append(int(i))
            done.add(cands[i][0])
    if not kept:
        return []
    return ax.clabel(cs, fmt=fmt, fontsize=fontsize, inline=True,
                     inline_spacing=inline_spacing,
                     manual=[tuple(cands[i][2]) for i in sorted(kept)])


def thin_values(fig, texts, groups=None):
    """The values at the calculation points kept on every k-th column and row of the
    grid, k as small as keeps their boxes apart on the drawn page, then any box still
    touching a kept one dropped (a small task area on a page-wide room printed its values
    as one run of digits: 0.25 m apart at about 0.5 inch a metre). ``groups`` ((n,) ints):
    the grid each value belongs to (task areas given explicitly each have their own
    spacing), thinned each on its own."""
    if len(texts) < 2:
        return
    if groups is not None and len(np.unique(groups)) > 1:
        groups = np.asarray(groups)
        keep = np.zeros(len(texts), dtype=bool)
        for g_ in np.unique(groups):
            idx = np.flatnonzero(groups == g_)
            keep[idx] = _thin_keep(fig, [texts[i] for i in idx])
        keep = _apart(fig, texts, keep)
    else:
        keep = _apart(fig, texts, _thin_keep(fig, texts))
    for t, k_ in zip(texts, keep):
        if not k_:
            t.remove()


def _boxes(fig, texts):
    renderer = fig.canvas.get_renderer()
    return np.array([t.get_window_extent(renderer).extents for t in texts])


def _apart(fig, texts, keep):
    """``keep`` less any value whose box touches one kept before it (padded a little)."""
    boxes = _boxes(fig, texts)
    size = np.max(boxes[:, 2:] - boxes[:, :2], axis=0)
    pad = 0.05 * size
    kept = []
    keep = keep.copy()
    for i in np.flatnonzero(keep):
        b = boxes[i] + np.r_[-pad, pad]
        if any(b[0] < c[2] and c[0] < b[2] and b[1] < c[3] and c[1] < b[3] for c in kept):
            keep[i] = False
            continue
        kept.append(b)
    return keep


def _thin_keep(fig, texts):
    """Which of one grid's values to keep: every k-th column and row (see
    :func:`thin_values`)."""
    if len(texts) < 2:
        return np.ones(len(texts), dtype=bool)
    ax = texts[0].axes
    ax.apply_aspect()           # the box as drawn (an equal aspect narrows it at drawing)
    at = ax.transData.transform(np.array([t.get_position() for t in texts]))
    boxes = _boxes(fig, texts)
    size = np.max(boxes[:, 2:] - boxes[:, :2], axis=0) * 1.15      # (w, h) px, a gap
    keep = np.ones(len(texts), dtype=bool)
    for d in (0, 1):
        levels, idx = np.unique(np.round(at[:, d], 1), return_inverse=True)
        if len(levels) < 2:
            continue
        pitch = float(np.median(np.diff(levels)))
        k = max(1, int(np.ceil(size[d] / max(pitch, 1e-9))))
        keep &= idx % k == 0
    return keep

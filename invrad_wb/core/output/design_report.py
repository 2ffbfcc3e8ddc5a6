"""The design report a lighting designer hands to a client (HTML + CSV + PNG).

Per room: the room summary as DIALux gives it (task area, immediate surroundings,
background area, walls, ceiling, cylindrical illuminance, UGR: required, achieved,
pass/fail each), Emin, Emax, the room's dimensions and reflectances, the luminaire
schedule (type, count, lm, W, efficacy, dimming), power drawn at the designed output and
installed (rated) W, W/m^2, W/m^2/100 lx, a deep-dimming flag and the energy per year
where operating hours are given, notes where the catalogue cannot comply, and the work-plane
plan: false colour over the EN 12464-1 calculation grid, labelled iso-lux lines, the value
of every grid point, the luminaires and the room outline. A whole-floor plan shows every
room with its luminaires and Em. Figures are drawn with matplotlib (Agg canvas, no pyplot
state, :mod:`invrad_wb.core.output.figures`), the page with a Jinja2 template (autoescape)
in the verification report's style, and printed to ``report.pdf`` beside it
(:mod:`invrad_wb.core.output.document`). The folder appears all at once
(:func:`invrad_wb.core.io.atomic.atomic_dir`).
"""
import csv
import datetime
import io
import os

import numpy as np

from invrad_wb.core.geometry.outline import inside_outline, outline_raster
from invrad_wb.core.io.atomic import atomic_dir
from invrad_wb.constants import DEEP_DIMMING, SPOT_TOLERANCE, SURFACE_REFERENCE
from invrad_wb.core.output import document
from invrad_wb.core.output.groups import output_groups  # noqa: F401 (the report's groups)
from invrad_wb.core.output.figures import (MARKER_HALF_PT, figure as _fig, iso_levels,
                                           label_iso_lines)
from invrad_wb.core.output.figures import thin_values
from invrad_wb.core.output.taskarea_report import (area_of, draw_task_outlines, iso_words,
                                                   per_area, task_area_figures)
from invrad_wb.core.output.figures import png as _png

_TEMPLATE = "design_report.html.j2"
#: grid values are printed on the plan up to this many points (else every k-th)
MAX_LABELS = 160
#: the plan's two panels one above the other are at most this high each (inches)
STACKED_PANEL_H = 3.3


def _figure(width_in, height_in):
    return _fig(width_in, height_in, dpi=110)


def _outline(ax, droom_edges):
    for a, b in droom_edges:
        ax.plot([a[0], b[0]], [a[1], b[1]], color="0.15", lw=1.6)


_MARKERS = "osD^vP*Xh"


def _marker(types, t):
    return _MARKERS[types.index(t) % len(_MARKERS)] if t in types else "o"


def _plot_luminaires(ax, luminaires, types, ms=8):
    """Luminaires by type; ``types`` is the whole report's list so that a type keeps its
    marker on every figure."""
    for t in types:
        p = np.array([lum.position for lum in luminaires if lum.extra.get("type") == t])
        if len(p):
            ax.plot(p[:, 0], p[:, 1], _marker(types, t), ms=ms, mfc="white",
                    mec="black", mew=1.4, label=t, zorder=5, gid="luminaires")


def _group_key_text(g):
    """A dimming group as the plan's key gives it."""
    return (f"{g['label']}: {g['count']} x {g['type']} at {g['percent']} %,"
            f" {g['flux_lm']:.0f} lm, {g['watts']:.1f} W each")


#: a marker's size (points) per point of the letter written in it, by marker: a triangle
#: or a star holds a letter only near its centre
_MARKER_SCALE = {"o": 1.6, "s": 1.5, "D": 1.9, "h": 1.7, "^": 2.3, "v": 2.3, "P": 2.3,
                 "*": 2.7, "X": 2.3}


#: the smallest letter written on a plan (points)
MIN_LABEL_PT = 4.5


def _label_fits(fig, ax, luminaires, groups):
    """Whether the group letters fit in their markers at ``MIN_LABEL_PT`` without two
    markers overlapping (see :func:`_label_luminaires`)."""
    return _label_size(fig, ax, luminaires, groups)[0] >= MIN_LABEL_PT - 1e-9


def _label_size(fig, ax, luminaires, groups):
    """(letter size in points before clipping, {luminaire index: letter}, marker lines)."""
    labels = {i: g["label"] for g in groups if g["label"] for i in g["members"]}
    lines = [ln for ln in ax.get_lines() if ln.get_gid() == "luminaires"]
    if not labels:
        return np.inf, labels, lines
    ax.apply_aspect()
    p = np.array([luminaires[i].position[:2] for i in labels], dtype=float)
    px = ax.transData.transform(p) * 72.0 / fig.dpi          # points on the page
    gap = np.inf
    if len(px) > 1:
        d = np.linalg.norm(px[:, None] - px[None], axis=2)
        gap = float(np.min(d[np.triu_indices(len(px), 1)]))
    scale = max(_MARKER_SCALE.get(ln.get_marker(), 2.3) for ln in lines) if lines else 1.6
    width = max(len(s) for s in labels.values())
    # a marker (scale x the letter's size, wider by 0.65 em a further letter) fits the gap
    return gap / (scale + 0.1 + 0.65 * (width - 1)), labels, lines


def _label_luminaires(fig, ax, luminaires, groups, max_size=7.0, force=False):
    """Write each luminaire's dimming-group letter inside its marker (rooms dimmed apart);
    markers and letters are sized to the closest two luminaires on the figure, so that no
    two markers (nor letters) overlap, between ``MIN_LABEL_PT`` and ``max_size``; a
    triangle's letter sits at its centroid. Where they would not fit at the smallest size
    nothing is written (unless ``force``: then at the smallest size); returns whether
    letters were written."""
    from matplotlib.transforms import offset_copy
    size, labels, lines = _label_size(fig, ax, luminaires, groups)
    if not labels or (size < MIN_LABEL_PT - 1e-9 and not force):
        return False
    size = float(np.clip(size, MIN_LABEL_PT, max_size))
    width = max(len(s) for s in labels.values())
    p = np.array([luminaires[i].position[:2] for i in labels], dtype=float)
    for line in lines:
        line.set_markersize(_MARKER_SCALE.get(line.get_marker(), 2.3) * size
                            + 0.65 * size * (width - 1))
        line.set_markeredgewidth(1.0)
    shift = {}
    for line in lines:
        ms = line.get_markersize()
        dy = {"^": -ms / 6.0, "v": ms / 6.0}.get(line.get_marker(), 0.0)
        for xy in np.column_stack(line.get_data()):
            shift[tuple(np.round(xy, 9))] = dy
    for s, q in zip(labels.values(), p):
        dy = shift.get(tuple(np.round(q, 9)), 0.0)
        tr = offset_copy(ax.transData, fig=fig, y=dy, units="points") if dy else ax.transData
        ax.text(q[0], q[1], s, fontsize=size, ha="center", va="center", zorder=6,
                fontweight="bold", gid="group-label", transform=tr)
    return True


def room_plan_png(rd, edges, lux_max, types, groups=None):
    """PNG bytes of :func:`room_plan_figure`."""
    return _png(room_plan_figure(rd, edges, lux_max, types, groups))


def room_plan_figure(rd, edges, lux_max, types, groups=None):
    """A room's work-plane plan: false colour, labelled iso-lux lines and the luminaires in
    one panel, the values at the calculation points in a second one beside it (below it for
    a long room), so that no number sits under a marker or an iso-lux label. ``groups``
    (:func:`output_groups`): a room dimmed apart gets each luminaire's group letter in its
    marker and the groups' key (type, output, lm, W, count) under the plan; an evenly
    dimmed one its types' output in the legend."""
    from matplotlib import patheffects
    pts, lux = rd.grid_points, rd.metrics.lux[:len(rd.grid_points)]
    lo, hi = np.min(edges, axis=(0, 1)), np.max(edges, axis=(0, 1))
    span = np.maximum(hi - lo, 1e-6)
    # side by side; one above the other for a long room or one with many grid columns
    # (the values need the page's width)
    columns = len(np.unique(np.round(pts[:, 0], 3))) if len(pts) else 0
    stacked = span[0] > 1.6 * span[1] or columns > 12
    w = 8.0
    panel_w = w - 1.3 if stacked else (w - 1.6) / 2
    # two panels stacked stay under STACKED_PANEL_H each: the figure with the room's
    # heading fits one page (4.2 in each left the heading alone on an empty page)
    panel_h = min(STACKED_PANEL_H if stacked else 4.2, panel_w * span[1] / span[0])
    # the key of a room dimmed apart: one line per group (two columns beyond three)
    keyed = [g for g in groups or [] if g["label"]]
    key_in = 0.15 * max(0, -(-len(keyed) // _key_columns(keyed)) - 1) if keyed else 0.0
    h = max(2.6, (2 * panel_h + 1.7) if stacked else panel_h + 1.25) + key_in
    fig = _figure(w, h)
    ax, ax2 = fig.subplots(2, 1) if stacked else fig.subplots(1, 2)
    m = _false_colour(ax, pts, lux, lux_max, rd.requirement.lux, edges)
    _outline(ax, edges)
    _plot_luminaires(ax, rd.luminaires, types)
    areas = task_area_figures(rd)
    iso = iso_words(lux, rd.requirement.lux)
    ax.set_title(("; " if stacked else "\n").join(
                     f"{a['name']}: Em {a['em']:.0f} lx, U0 {a['u0']:.2f}"
                     for a in areas) + f"\n{iso}" if areas else
                 f"Em {rd.metrics.em:.0f} lx, U0 {rd.metrics.u0:.2f}\n{iso}",
                 fontsize=8)
    step = max(1, int(np.ceil(len(pts) / MAX_LABELS)))
    # a white halo: a value printed over a task area's dashed outline stays readable
    # ("328" read "528" where the dash crossed its first digit)
    halo = [patheffects.withStroke(linewidth=1.6, foreground="white")]
    values = [ax2.text(p[0], p[1], f"{v:.0f}", fontsize=5.5, ha="center", va="center",
                       color="black", zorder=4, path_effects=halo)
              for p, v in zip(pts[::step], lux[::step])]
    _outline(ax2, edges)
    draw_task_outlines((ax, ax2), rd)
    ax2.set_title("values (lx) at the calculation points", fontsize=8)
    for a_ in (ax, ax2):
        a_.set_aspect("equal")
        a_.set_xlabel("x (m)", fontsize=7)
        a_.set_ylabel("y (m)", fontsize=7)
        a_.tick_params(labelsize=6.5)
    # room under the panels for the x label and the key (its group lines)
    bottom = ((min(0.17 * (h - key_in), 0.95) + key_in) / h) if rd.luminaires else 0.1
    fig.subplots_adjust(wspace=0.3, hspace=0.45, bottom=bottom)
    if m is not None:
        bar = fig.colorbar(m, ax=[ax, ax2], shrink=0.8, pad=0.03)
        bar.set_label("maintained illuminance (lx)", fontsize=7)
        bar.ax.tick_params(labelsize=6.5)
    if rd.luminaires:
        fits = _label_fits(fig, ax, rd.luminaires, groups or [])
        _room_legend(fig, ax, types, groups or [], fits)
        if fits:
            _label_luminaires(fig, ax, rd.luminaires, groups or [])
    if getattr(ax, "iso_lines", None) is not None:
        # the markers as drawn: a letter in them makes them 2-3 times the plain size
        # (FZK's Galerie had its '400 lx' half under a lettered triangle)
        half = max([0.5 * (ln.get_markersize() + ln.get_markeredgewidth())
                    for ln in ax.get_lines() if ln.get_gid() == "luminaires"] or [0.0])
        label_iso_lines(ax, ax.iso_lines, rd.requirement.lux,
                        avoid=[lum.position[:2] for lum in rd.luminaires],
                        field=ax.iso_field, avoid_half_pt=max(half, MARKER_HALF_PT))
    thin_values(fig, values, None if not areas else area_of(pts[::step], rd))
    return fig


def dimming_plan_png(rd, edges, types, groups):
    """PNG bytes of :func:`dimming_plan_figure`."""
    return _png(dimming_plan_figure(rd, edges, types, groups))


def dimming_plan_figure(rd, edges, types, groups):
    """The commissioning plan of a room dimmed apart: its outline and luminaires at the
    page's width, each marked with its dimming group's letter, and the groups' key (type,
    output, lm and W each, count) beside it (under it where its lines are too long)."""
    from matplotlib.lines import Line2D
    lo, hi = np.min(edges, axis=(0, 1)), np.max(edges, axis=(0, 1))
    span = np.maximum(hi - lo, 1e-6)
    keyed = [g for g in groups if g["label"]]
    texts = [_group_key_text(g) for g in keyed]
    line_in = 0.19                          # a key line at 8 pt, inches
    # the key's width at 8 pt (about 0.06 in a character) and its marker
    key_w = 0.45 + 0.06 * max([len(t) for t in texts] or [0])
    below = key_w > 4.3
    w = 8.0
    panel_w = w - 0.9 if below else w - key_w - 0.7
    panel_h = min(5.0, panel_w * span[1] / span[0])
    key_h = line_in * (len(texts) + 1)
    h = max(2.4, panel_h + 0.9 + (key_h + 0.2 if below else 0), key_h + 0.5)
    fig = _figure(w, h)
    bottom = (key_h + 0.75) if below else 0.55
    ax = fig.add_axes([0.6 / w, bottom / h, panel_w / w, (h - bottom - 0.3) / h])
    _outline(ax, edges)
    _plot_luminaires(ax, rd.luminaires, types)
    ax.set_aspect("equal", anchor="W" if not below else "C")
    ax.set_xlabel("x (m)", fontsize=7)
    ax.set_ylabel("y (m)", fontsize=7)
    ax.tick_params(labelsize=6.5)
    ax.set_title(f"{rd.name}: dimming groups", fontsize=8)
    handles = [Line2D([], [], ls="", marker=_marker(types, g["type"]), ms=5, mfc="white",
                      mec="black", mew=1.0) for g in keyed]
    fig.legend(handles, texts, loc="upper left",
               bbox_to_anchor=(0.6 / w, (key_h + 0.2) / h) if below
               else ((w - key_w) / w, 1 - 0.3 / h), fontsize=8, frameon=False,
               title="group: output of the rated flux", title_fontsize=8)
    _label_luminaires(fig, ax, rd.luminaires, groups, max_size=9.0, force=True)
    return fig


def _key_columns(groups):
    """Columns of a room plan's group key: two beyond three groups where two lines fit
    the figure's width side by side (about 55 characters each at 7 pt)."""
    longest = max([len(_group_key_text(g)) for g in groups] or [0])
    return 2 if len(groups) > 3 and longest <= 55 else 1


def _room_legend(fig, ax, types, groups, lettered=True):
    """The plan's key: per type (and its output where the room dims it evenly), or per
    dimming group (letter, type, output, lm and W each, count) where it dims apart
    (``lettered``: the letters are on this plan, else on the commissioning plan only)."""
    from matplotlib.lines import Line2D
    handles, labels = ax.get_legend_handles_labels()
    if any(g["label"] for g in groups):
        handles = [Line2D([], [], ls="", marker=_marker(types, g["type"]), ms=5, mfc="white",
                          mec="black", mew=1.0) for g in groups]
        labels = [_group_key_text(g) for g in groups]
        title = ("dimming groups (letters on the plan; output of the rated flux)" if lettered
                 else "dimming groups (too close to letter here: see the commissioning plan)")
        ncol = _key_columns(groups)
    else:
        out = {g["type"]: g["percent"] for g in groups}
        labels = [f"{t} at {out[t]} %" if out.get(t, 100) != 100 else t for t in labels]
        title, ncol = "luminaires", min(len(types), 5)
    fig.legend(handles, labels, loc="lower center", fontsize=7, ncol=ncol,
               frameon=False, title=title, title_fontsize=7)


def _false_colour(ax, pts, lux, lux_max, required, edges=None):
    """Gouraud false colour of the work plane with labelled iso-lux lines; the mappable
    (None with fewer than three points)."""
    from matplotlib.tri import Triangulation
    if len(pts) == 0:
        return None
    centred = pts[:, :2] - pts[:, :2].mean(axis=0)
    if len(pts) < 3 or np.linalg.matrix_rank(centred, tol=1e-6) < 2:
        # one row of calculation points (a corridor narrower than two grid cells): no
        # triangulation; each point's colour as a square
        return ax.scatter(pts[:, 0], pts[:, 1], c=lux, cmap="viridis", vmin=0, vmax=lux_max,
                          marker="s", s=60, linewidths=0)
    tri = Triangulation(pts[:, 0], pts[:, 1])
    # Delaunay fills the convex hull: no colour over a notch outside the room (an L-shaped
    # room's missing corner was painted): triangles longer than a grid cell's diagonal
    # (they bridge the notch) or with their centre outside the outline are left out
    corner = pts[tri.triangles][..., :2]
    longest = np.max(np.linalg.norm(corner - np.roll(corner, 1, axis=1), axis=2), axis=1)
    cell = np.median(np.min(np.linalg.norm(corner - np.roll(corner, 1, axis=1), axis=2),
                            axis=1))
    mask = longest > 1.5 * np.sqrt(2.0) * cell
    if edges is not None:
        mask |= ~inside_outline(np.asarray(edges, dtype=float)[:, :, :2], corner.mean(axis=1))
    if not mask.all():
        tri.set_mask(mask)
    m = ax.tripcolor(tri, lux, shading="gouraud", cmap="viridis", vmin=0, vmax=lux_max)
    levels = iso_levels(lux, required)
    ax.iso_lines = None      # labelled once the page's layout is final (label_iso_lines)
    if len(levels):
        # the required level's line bold: it says where the requirement is met even
        # where no label fits between the luminaires' markers
        req = [required is not None and abs(v - required) < 1e-6 for v in levels]
        ax.iso_lines = ax.tricontour(tri, lux, levels=levels, colors="white",
                                     linewidths=[2.2 if r else 0.9 for r in req])
        ax.iso_field = tri
    return m


def label_point(edges, avoid, n=25, half_size=None):
    """A point inside a room's outline as far as possible from its walls and from the
    points ``avoid`` (luminaires): where its label overlaps neither (pole of
    inaccessibility on an n x n raster; odd n puts the middle on it). ``half_size`` (hx, hy), metres: the label's half
    width and height; the distance to a point then counts in label boxes (a wide label
    keeps further from points beside it than from points above it)."""
    g, lo, hi = outline_raster(edges, n)
    if len(g) == 0:
        return edges.reshape(-1, 2).mean(axis=0)
    a, b = edges[:, 0], edges[:, 1]
    ab = b - a
    t = np.clip(np.einsum("kij,ij->ki", g[:, None] - a, ab) / np.maximum(
        np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
    d = np.linalg.norm(g[:, None] - (a + t[..., None] * ab), axis=2).min(axis=1)
    if len(avoid):
        diff = g[:, None] - np.asarray(avoid, dtype=np.float64).reshape(-1, 2)[None]
        if half_size is None:
            da = np.linalg.norm(diff, axis=2)
        else:
            hx, hy = half_size
            # box distance in label units, back in metres on the label's height scale
            da = np.max(np.abs(diff) / np.array([hx, hy]), axis=2) * hy
        d = np.minimum(d, da.min(axis=1))
    # of the points within a quarter raster step of the best clearance, the one nearest
    # the middle (an empty rectangle's clearance ridge is a whole segment)
    step = float(np.min((hi - lo) / (n - 1)))
    near_best = d >= d.max() - 0.25 * step
    mid = 0.5 * (lo + hi)
    k = np.flatnonzero(near_best)
    return g[k[int(np.argmin(np.linalg.norm(g[k] - mid, axis=1)))]]


def storeys(rooms, step=0.5):
    """Designed rooms grouped by floor height: [(z, [RoomDesign, ...]), ...] bottom up."""
    out = {}
    for r in rooms:
        if r.outline is not None:
            out.setdefault(round(r.floor_z / step) * step, []).append(r)
    return [(min(r.floor_z for r in rs), rs) for _, rs in sorted(out.items())]


def floor_plan_png(rooms, z, types, catalogue=None):
    """PNG bytes of :func:`floor_plan_figure`."""
    return _png(floor_plan_figure(rooms, z, types, catalogue))


def floor_plan_figure(rooms, z, types, catalogue=None):
    """One storey's rooms in plan: outlines, luminaires, Em per room; with ``catalogue``,
    each luminaire of a room dimmed apart carries its dimming group's letter (the room's
    groups in the schedule)."""
    allp = np.concatenate([r.outline.reshape(-1, 2) for r in rooms])
    span = allp.max(axis=0) - allp.min(axis=0)
    fig = _figure(9.0, max(3.5, min(10.0, 9.0 * span[1] / max(span[0], 1e-6) + 0.8)))
    ax = fig.add_subplot(1, 1, 1)
    for r in rooms:
        _outline(ax, r.outline)
        c = label_point(r.outline, [lum.position[:2] for lum in r.luminaires])
        areas = task_area_figures(r)
        text = (r.name if r.metrics is None else f"{r.name}\nEm {r.metrics.em:.0f} lx"
                if not areas else r.name + "".join(f"\n{a['name']}: Em {a['em']:.0f} lx"
                                                    for a in areas))
        ok = r.metrics is not None and r.compliant
        ax.text(c[0], c[1], text, ha="center", va="center", fontsize=8,
                color="darkgreen" if ok else "darkred",
                bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.6", alpha=0.85))
    lums = [lum for r in rooms for lum in r.luminaires]
    _plot_luminaires(ax, lums, types)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"Floor plan, floor at {z:.2f} m: rooms, luminaires and maintained Em",
                 fontsize=10)
    if lums:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    if catalogue is not None and lums:
        groups, k = [], 0
        for r in rooms:
            for g in output_groups(r, catalogue):
                groups.append({**g, "members": [k + i for i in g["members"]]})
            k += len(r.luminaires)
        _label_luminaires(fig, ax, lums, groups, max_size=9.0)
    return fig


def schedule_rows(result):
    """Rows of the luminaire schedule: one per room, type and output setting (dicts; a
    type dimmed apart has a row per dimming group, its letter as on the plans, lm and W
    each at that output, W total its members' own watts)."""
    cat = {e.name: e for e in result.spec.catalogue}
    rows = []
    for r in result.rooms:
        for g in output_groups(r, result.spec.catalogue):
            rows.append({"room": r.name, "group": g["label"], "type": g["type"],
                         "count": g["count"], "flux_lm": round(g["flux_lm"]),
                         "watts": round(g["watts"], 2), "dim_percent": g["percent"],
                         "watts_total": round(g["watts_total"], 2),
                         "efficacy": round(cat[g["type"]].efficacy, 1)})
    return rows


def _entry_photometry(e):
    """A catalogue entry's intensity distribution: its file's, else lambertian (None when
    the file cannot be read: the design would have said so already)."""
    from invrad_wb.core.model.photometry import Photometry, read_photometry
    if not e.photometry:
        return Photometry.lambertian()
    try:
        return read_photometry(e.photometry)
    except Exception:             # noqa: BLE001 - the sheet shows what it can
        return None


def _luminous_text(e, ph):
    """Luminous area of an entry as the UGR uses it (m^2 and its shape), or a note."""
    import math
    if e.radius_m > 0:
        return f"{math.pi * e.radius_m ** 2:.3f} m² (round, Ø {2000 * e.radius_m:.0f} mm)"
    area = getattr(ph, "luminous_area_m2", None) if e.photometry else None
    if area:
        ext = getattr(ph, "luminous_extent_m", None)
        shape = (f", {1000 * ext[0]:.0f} x {1000 * ext[1]:.0f} mm (C0 x C90)"
                 if ext else " (from the file)")
        return f"{area:.3f} m²{shape}"
    return "not given: rated as a CIE 147 small source for UGR"


def polar_png(e, ph):
    """PNG bytes of an entry's polar curve: cd per 1000 lm in the C0-C180 and C90-C270
    planes (gamma 0 pointing down, as luminaire data sheets draw it)."""
    g = np.arange(0, 181)
    t = ph.table * 1000.0
    fig = _fig(3.4, 3.4, dpi=110)
    ax = fig.add_subplot(111, projection="polar")
    ax.set_theta_zero_location("S")
    for (c_a, c_b), style, label in (((0, 180), "-", "C0-C180"),
                                     ((90, 270), "--", "C90-C270")):
        theta = np.radians(np.r_[-g[::-1], g[1:]])
        r = np.r_[t[c_b][::-1], t[c_a][1:]]
        ax.plot(theta, r, style, color="black" if c_a == 0 else "#c0392b", lw=1.4,
                label=label)
    ax.set_thetagrids(range(0, 360, 30), [f"{a if a <= 180 else 360 - a}°"
                                          for a in range(0, 360, 30)], fontsize=7)
    ax.tick_params(axis="y", labelsize=7)
    ax.set_title(f"{e.name}: cd / 1000 lm", fontsize=9)
    ax.legend(loc="upper right", bbox_to_anchor=(1.15, 1.12), fontsize=7, frameon=False)
    return _png(fig)


def datasheet_rows(result):
    """One data sheet per catalogue type the design uses: flux, power, efficacy, dimming,
    luminous area, its photometry file and the polar curve's PNG name (dicts)."""
    used = {lum.extra.get("type") for r in result.rooms for lum in r.luminaires}
    rows = []
    for i, e in enumerate(result.spec.catalogue):
        if e.name not in used:
            continue
        ph = _entry_photometry(e)
        rows.append({"entry": e, "ph": ph, "name": e.name, "flux_lm": f"{e.flux_lm:.0f}",
                     "watts": f"{e.watts:g}", "efficacy": f"{e.efficacy:.1f}",
                     "dimming": (f"{100 * e.dimming[0]:.0f}-{100 * e.dimming[1]:.0f} %"
                                 if e.dimming[0] < e.dimming[1] else "not dimmable"),
                     "area": _luminous_text(e, ph),
                     "photometry": (os.path.basename(e.photometry) if e.photometry
                                    else "none given: lambertian (cos γ / π)"),
                     "polar": f"polar_{i}.png" if ph is not None else None})
    return rows


def _csv(rows, fields):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    return buf.getvalue()


def summary_rows(r):
    """The room summary as DIALux gives it: one row per EN 12464-1 item (task area,
    immediate surroundings, background area, walls, ceiling, cylindrical illuminance, UGR)
    with its requirement, the achieved figure and the verdict ('pass', 'FAIL', or '-'
    where the item is stated but not computed, or the room has none)."""
    m, q, v = r.metrics, r.requirement, r.verdicts
    rows = [{"item": "task area (work plane)",
             "required": f"Em >= {q.lux:g} lx, U0 >= {q.u0:.2f}",
             "achieved": f"Em {m.em:.0f} lx, U0 {m.u0:.2f}",
             "verdict": "pass" if v["Em"] and v["U0"] else "FAIL", "source": q.source},
            ] if not task_area_figures(r) else [
        {"item": f"task area {a['name']} ({a['area_m2']:.2f} m2)",
         "required": f"Em >= {a['lux']:g} lx, U0 >= {a['u0_req']:.2f}",
         "achieved": f"Em {a['em']:.0f} lx, U0 {a['u0']:.2f}",
         "verdict": "pass" if a["ok"] else "FAIL", "source": a["source"]}
        for a in task_area_figures(r)]
    # the two bands around the task area: judged where the room has them, else why not
    for key, item, lux_fmt, none_words, none_source in (
            ("surroundings", "immediate surroundings", "g", "not computed",
             "the task area has no border zone around it"),
            ("background", "background area", ".4g",
             getattr(r, "background_words", None) or "not computed",
             "EN 12464-1:2021 4.3.3")):
        # one row per Table-3 level where task areas ask for several ('surroundings (desks)')
        keys = [k for k in r.surface_reqs if k.startswith(key) and k in m.surfaces]
        for k in keys:
            bq, (em, _, u0) = r.surface_reqs[k], m.surfaces[k]
            rows.append({"item": item + k[len(key):],
                         "required": f"Em >= {bq.lux:{lux_fmt}} lx, U0 >= {bq.u0:.2f}",
                         "achieved": f"Em {em:.0f} lx, U0 {u0:.2f}",
                         "verdict": "pass" if v.get(k) else "FAIL", "source": bq.source})
        if not keys:
            rows.append({"item": item, "required": "-", "achieved": none_words,
                         "verdict": "-", "source": none_source})
    for part in ("walls", "ceiling"):
        sq = r.surface_reqs.get(part)
        if sq is None:
            continue
        em, _, u0 = m.surfaces[part]
        rows.append({"item": part, "required": f"Em >= {sq.lux:g} lx, U0 >= {sq.u0:.2f}",
                     "achieved": f"Em {em:.0f} lx, U0 {u0:.2f}",
                     "verdict": "pass" if v.get(part) else "FAIL", "source": sq.source})
    if r.cylindrical is not None:
        c = r.cylindrical
        f = r.cyl_figures
        mod = ("" if f is None or f["modelling"] is None
               else f"; modelling Ez/Eh {f['modelling']:.2f} (0.30-0.60 recommended)")
        rows.append({"item": "cylindrical illuminance Ez",
                     "required": f"Ez >= {c['lux']:g} lx, U0 >= {c['u0']:.2f}"
                                 f" at {c['height_m']:g} m",
                     "achieved": ("not computed" if f is None else
                                  f"Ez {f['em_lux']:.0f} lx, U0 {f['u0']:.2f}{mod}"),
                     "verdict": ("-" if "Ez" not in v else "pass" if v["Ez"] else "FAIL"),
                     "source": "spec or room type (EN 12464-1:2021 4.6.2)"})
    ugr = "not computable" if r.ugr is None else ("< 10" if r.ugr < 10 else f"{r.ugr:.1f}")
    rows.append({"item": "UGR (CIE 117, worst standard observer, installation new)",
                 "required": "-" if r.ugr_limit is None else f"<= {r.ugr_limit:g}",
                 "achieved": ugr,
                 "verdict": ("-" if "UGR" not in v else "pass" if v["UGR"] else "FAIL"),
                 "source": "spec or room type" if r.ugr_limit is not None else "no limit given"})
    return rows


def room_rows(result):
    """Rows of the compliance table: one per room (dicts, strings formatted)."""
    rows = []
    for r in result.rooms:
        row = {"name": r.name, "area": f"{r.area_m2:.1f}",
               "size": " x ".join(f"{x:.2f}" for x in r.size_m),
               "reflectance": ", ".join(f"{k} {v:.2f}" for k, v in r.reflectance.items()),
               "notes": r.notes, "designed": r.metrics is not None}
        if r.metrics is not None:
            m, q, v = r.metrics, r.requirement, r.verdicts
            row.update(em_req=f"{q.lux:g}", em=f"{m.em:.0f}", emin=f"{m.emin:.0f}",
                       emax=f"{m.emax:.0f}", u0_req=f"{q.u0:.2f}", u0=f"{m.u0:.2f}",
                       em_ok=v.get("Em"), u0_ok=v.get("U0"), ok=r.compliant,
                       watts=f"{r.watts:.1f}", wpm2=f"{r.watts / max(r.area_m2, 1e-9):.2f}",
                       layout=r.candidate.geom.describe(), source=q.source,
                       ugr="n/c" if r.ugr is None else f"{r.ugr:.1f}",
                       ugr_limit="-" if r.ugr_limit is None else f"{r.ugr_limit:g}",
                       # None: no limit, no verdict (the value in plain text, not
                       # green as if it passed: "UGR 37.6" under "-" read as met)
                       ugr_ok=v.get("UGR"),
                       height=f"{q.height_m:g}", margin=f"{q.margin_m:g}",
                       summary=summary_rows(r),
                       walls=_surface_text(r, "walls"), ceiling=_surface_text(r, "ceiling"),
                       surroundings=_surface_text(r, "surroundings"),
                       background=_surface_text(r, "background"),
                       walls_ok=v.get("walls", True), ceiling_ok=v.get("ceiling", True),
                       designed_w=f"{r.watts:.1f}", rated_w=f"{r.rated_watts:.1f}",
                       rated_wpm2=f"{r.w_per_m2:.2f}",
                       wpm2_100lx=("-" if r.w_per_m2_100lx is None
                                   else f"{r.w_per_m2_100lx:.2f}"),
                       output=_output_text(r),
                       deep_dimming=r.deep_dimming, deep_text=_deep_text(r),
                       groups=[{**g, "flux_lm": f"{g['flux_lm']:.0f}",
                                "watts": f"{g['watts']:.1f}",
                                "watts_total": f"{g['watts_total']:.1f}"}
                               for g in output_groups(r, result.spec.catalogue)
                               if g["label"]],
                       energy=(None if r.energy_kwh is None else f"{r.energy_kwh:.0f}"),
                       hours=(None if r.operating_hours is None
                              else f"{r.operating_hours:g}"),
                       leni=(None if r.energy_kwh is None
                             else f"{r.energy_kwh / max(r.area_m2, 1e-9):.1f}"),
                       spots=[{"centre": ", ".join(f"{x:.2f}" for x in s.goal.centre),
                               "tol": f"{100 * SPOT_TOLERANCE:.0f} %",
                               "target": f"{s.goal.target_mean:.0f}",
                               "achieved": f"{s.achieved_mean:.0f}", "ok": s.ok,
                               "accent": (s.accent_words() if hasattr(s, "accent_words")
                                          else None if s.accent is None
                                          else s.accent.extra.get("type"))}
                              for s in r.spots if s.goal.kind == "spot"])
        areas = task_area_figures(r)
        if areas:        # one figure per task area, in the spec's order
            row.update(em_req=per_area(areas, lambda a: f"{a['lux']:g}"),
                       em=per_area(areas, lambda a: f"{a['em']:.0f}"),
                       emin=per_area(areas, lambda a: f"{a['emin']:.0f}"),
                       emax="-",
                       u0_req=per_area(areas, lambda a: f"{a['u0_req']:.2f}"),
                       u0=per_area(areas, lambda a: f"{a['u0']:.2f}"),
                       em_ok=all(a["em"] >= a["lux"] - 1e-9 for a in areas),
                       u0_ok=all(a["u0"] >= a["u0_req"] - 1e-9 for a in areas),
                       margin="-", task_areas=per_area(
                           areas, lambda a: f"{a['name']}: Em {a['em']:.0f} lx"
                           f" (>= {a['lux']:g}), U0 {a['u0']:.2f} (>= {a['u0_req']:.2f}),"
                           f" {'pass' if a['ok'] else 'FAIL'}"),
                       task_area_names=", ".join(a["name"] for a in areas))
        rows.append(row)
    return rows


def _output_text(r):
    """The general lighting's output as the room table gives it: '32 %' where it is dimmed
    evenly, '10 to 100 % (dimmed apart; 32 % of the rated power on average)' where
    not."""
    x = 100 * r.general_outputs()
    if not len(x):
        return "-"
    lo, hi = float(np.min(x)), float(np.max(x))
    if round(lo) == round(hi):
        return f"{lo:.0f} %"
    return (f"{lo:.0f} to {hi:.0f} % (dimmed apart; {100 * r.candidate.dim:.0f} % of the"
            " rated power on average)")


def _deep_text(r):
    """'9 of 15 DL-3500 below 50 %' per type (each luminaire's own output; 'all 4 ...',
    'the DL-3500 ...'), or ''."""
    return "; ".join(f"the {t}" if n == 1 else f"all {n} {t}" if low == n
                     else f"{low} of {n} {t}"
                     for t, (low, n) in sorted(r.deep_dimmed().items())
                     ) + (f" below {100 * DEEP_DIMMING:.0f} %" if r.deep_dimming else "")


def _surface_text(r, part):
    """'Em lx / U0' of a surface grid, or '-'; of each grid named ``part (...)`` where the
    task areas' surroundings come at several levels: '(desks) 320 / 0.55; ...'."""
    if r.metrics is None:
        return "-"
    if part in r.metrics.surfaces:
        em, _, u0 = r.metrics.surfaces[part]
        return f"{em:.0f} / {u0:.2f}"
    parts = [k for k in r.metrics.surfaces if k.startswith(part + " (")]
    return "; ".join(f"{k[len(part) + 1:]} {_surface_text(r, k)}" for k in parts) or "-"


def write_design_report(result, out_dir, title="Lighting design", project=None, pdf=True,
                        notes=None):
    """Write the report folder (``index.html``, ``report.pdf``, ``schedule.csv``,
    ``rooms.csv``, plans).

    Parameters
    ----------
    result : DesignResult (rooms carry their ``outline`` and ``floor_z``)
    out_dir : folder, replaced as a whole
    pdf : bool, also print ``report.pdf`` (WeasyPrint; without it a line is appended to
        ``notes`` and the rest is written)
    notes : list, optional, receives such lines
    Returns the path of ``index.html``.
    """
    notes = [] if notes is None else notes
    designed = [r for r in result.rooms if r.metrics is not None]
    lux_max = max([float(np.max(r.metrics.lux[:len(r.grid_points)])) for r in designed]
                  or [1.0])
    sched = schedule_rows(result)
    types = [e.name for e in result.spec.catalogue]
    with atomic_dir(out_dir) as tmp:
        plans, floors, dimming = {}, [], {}
        for r in designed:
            name = f"plan_room{r.room}.png"
            groups = output_groups(r, result.spec.catalogue)
            _write(tmp, name, room_plan_png(r, r.outline, lux_max, types, groups))
            plans[r.name] = name
            if any(g["label"] for g in groups):
                name = f"dimming_room{r.room}.png"
                _write(tmp, name, dimming_plan_png(r, r.outline, types, groups))
                dimming[r.name] = name
        for i, (z, rooms) in enumerate(storeys(result.rooms)):
            name = f"floor_plan_{i}.png"
            _write(tmp, name, floor_plan_png(rooms, z, types, result.spec.catalogue))
            floors.append({"file": name, "z": f"{z:.2f}"})
        sheets = datasheet_rows(result)
        for sh in sheets:
            if sh["polar"]:
                _write(tmp, sh["polar"], polar_png(sh["entry"], sh["ph"]))
        _write(tmp, "schedule.csv", _csv(sched, list(sched[0]) if sched else ["room"]))
        rows = room_rows(result)
        _write(tmp, "rooms.csv", _csv(rows, ["name", "area", "size", "em_req", "em", "emin",
                                              "emax", "u0_req", "u0", "task_areas", "surroundings",
                                              "background", "walls", "ceiling",
                                              "ugr", "ugr_limit", "ok", "watts", "rated_w",
                                              "rated_wpm2", "wpm2_100lx", "energy",
                                              "layout"]))
        area = sum(r.area_m2 for r in designed)
        html = document.render_page(
            _TEMPLATE, title=title, project=project, date=datetime.date.today().isoformat(),
            mf=result.spec.maintenance_factor, rooms=rows, plans=plans, schedule=sched,
            dimming_plans=dimming,
            total_w=f"{result.watts:.1f}", total_wpm2=f"{result.watts / max(area, 1e-9):.2f}",
            rated_w=f"{result.rated_watts:.1f}",
            rated_wpm2=f"{result.rated_watts / max(area, 1e-9):.2f}",
            energy=(None if result.energy_kwh is None else f"{result.energy_kwh:.0f}"),
            surface_ref=SURFACE_REFERENCE,
            compliant=result.compliant, n_lum=len(result.luminaires),
            catalogue=result.spec.catalogue, floors=floors, sheets=sheets)
        _write(tmp, "index.html", html)
        if pdf:
            try:
                document.write_pdf(html, tmp, os.path.join(tmp, "report.pdf"))
            except document.PdfUnavailable as exc:
                notes.append(str(exc))
    return os.path.join(out_dir, "index.html")


def _write(folder, name, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(os.path.join(folder, name), mode, **({} if mode == "wb" else
                                                   {"encoding": "utf-8"})) as fh:
        fh.write(data)

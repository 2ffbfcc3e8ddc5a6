"""Vote maps as images for a person to look at (the thesis saved its vote textures too).

For each room: one greyscale PNG per map, all maps scaled jointly to 0-255 (planes and dummy
planes together, so their brightness compares), the raw float votes as EXR, a contact sheet
(every map titled by the surface or dummy layer it is, in metres, on one colour scale, the
vote peaks circled in blue and the luminaires found crossed in red, with a legend), and ``maps.json`` describing each map's geometry (origin, u, v,
metres per pixel) so a pixel can be turned into a position.

Image rows are the map's first index (u), columns its second (v).
"""
import json
import os

import numpy as np

from invrad_wb.core.io.atomic import atomic_write_text
from invrad_wb.core.output.images import save_png, save_exr
from invrad_wb.core.output.report import facing_text


#: Maps per row of the contact sheet.
SHEET_COLUMNS = 4


def _map_title(m):
    """What a map is, for a person: the surface it lies on or the dummy layer's height."""
    if m.kind == "surface":
        n = m.normal
        where = ("floor" if n[2] > 0.9 else "ceiling" if n[2] < -0.9 else
                 f"wall facing {facing_text(n)}")
        return f"plane {m.plane}: {where}"
    side = "facing down" if m.normal[2] < 0 else "facing up"
    return f"dummy layer z = {m.height:.2f} m, {side}"


def contact_sheet(path, canvas, maps, top, peaks, found, label):
    """Every vote map of a room on one page (matplotlib): titled, in metres along the map's
    u and v, one joint colour scale, vote peaks and the luminaires found marked, a legend.

    ``maps``: the vote arrays of ``canvas.maps``; ``peaks``/``found``: {map index: [(u, v)
    metres]}.
    """
    from matplotlib.figure import Figure
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    n = len(maps)
    cols = min(SHEET_COLUMNS, n)
    rows = -(-n // cols)
    fig = Figure(figsize=(3.6 * cols + 1.2, 3.3 * rows + 0.9), dpi=100)
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(rows, cols + 1, width_ratios=[1] * cols + [0.06],
                            left=0.05, right=0.95, top=1 - 0.75 / (3.3 * rows + 0.9),
                            bottom=0.35 / (3.3 * rows + 0.9), wspace=0.35, hspace=0.5)
    vmax = top if top > 0 else 1.0
    image = None
    for k, (m, a) in enumerate(zip(canvas.maps, maps)):
        ax = fig.add_subplot(grid[k // cols, k % cols])
        shown = np.ma.masked_array(a, ~m.mask)
        nu, nv = m.shape
        image = ax.imshow(shown.T, origin="lower", cmap="magma", vmin=0, vmax=vmax,
                          extent=(0, nu * m.pixel, 0, nv * m.pixel), interpolation="nearest")
        image.cmap.set_bad("#c8c8d2")
        pk = np.asarray(peaks.get(k, [])).reshape(-1, 2)
        if len(pk):
            ax.scatter(pk[:, 0], pk[:, 1], s=40, facecolors="none", edgecolors="#3c78ff",
                       linewidths=1.2, label="vote peak")
        fd = np.asarray(found.get(k, [])).reshape(-1, 2)
        if len(fd):
            ax.scatter(fd[:, 0], fd[:, 1], s=70, marker="x", color="#ff2020",
                       linewidths=2, label="luminaire found")
        ax.set_title(_map_title(m), fontsize=9)
        ax.set_xlabel("u (m)", fontsize=8)
        ax.set_ylabel("v (m)", fontsize=8)
        ax.tick_params(labelsize=7)
    if image is not None:
        cax = fig.add_subplot(grid[:, cols])
        bar = fig.colorbar(image, cax=cax)
        bar.set_label("votes (one scale for every map)", fontsize=8)
        bar.ax.tick_params(labelsize=7)
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], marker="o", linestyle="", markerfacecolor="none",
                      markeredgecolor="#3c78ff", label="vote peak (a refinement start)"),
               Line2D([], [], marker="x", linestyle="", color="#ff2020", markersize=8,
                      markeredgewidth=2, label="luminaire found"),
               Line2D([], [], marker="s", linestyle="", color="#c8c8d2", markersize=8,
                      label="no luminaire possible")]
    fig.legend(handles=handles, loc="upper right", ncol=3, fontsize=8, frameon=False)
    fig.suptitle(f"{label}: vote maps (u, v: the map's own axes, see maps.json)",
                 x=0.05, ha="left", fontsize=11)
    fig.savefig(path)


def save_vote_maps(result, folder):
    """Write the vote maps of a :class:`LocateResult`; returns the list of files written.

    Every ``room<N>`` folder is written into a private staging folder first and moved into
    ``folder`` only when all are complete: an interrupted run (Ctrl-C, a full disk) leaves
    the previous maps, never a mix. Other files in ``folder`` are left alone.
    """
    import shutil
    import tempfile
    from invrad_wb.core.io.atomic import replace_dir, remove_stale, temp_prefix
    folder = os.path.abspath(folder)
    os.makedirs(folder, exist_ok=True)
    remove_stale(folder)
    stage = tempfile.mkdtemp(prefix=temp_prefix(), dir=folder)
    try:
        written = _save_rooms(result, stage)
        for name in sorted({os.path.relpath(w, stage).split(os.sep)[0] for w in written}):
            replace_dir(os.path.join(stage, name), os.path.join(folder, name))
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return [os.path.join(folder, os.path.relpath(w, stage)) for w in written]


def _save_rooms(result, folder):
    written = []
    for run in result.rooms:
        canvas = run.canvas
        maps = canvas.split(run.votes)
        top = max([float(a.max()) for a in maps if a.size], default=0.0)
        scale = 255.0 / top if top > 0 else 0.0
        room_dir = os.path.join(folder, f"room{run.room}")
        os.makedirs(room_dir, exist_ok=True)
        meta = []
        peaks, found = {}, {}
        for L in run.lights:
            m = canvas.maps[L.map_index]
            d = L.position - m.origin
            found.setdefault(L.map_index, []).append((d @ m.u, d @ m.v))
        for pk in run.peaks:
            m = canvas.maps[pk.map_index]
            peaks.setdefault(pk.map_index, []).append((pk.ij[0] * m.pixel,
                                                       pk.ij[1] * m.pixel))
        for k, (m, a) in enumerate(zip(canvas.maps, maps)):
            grey = np.clip(a * scale, 0, 255).astype(np.uint8)
            grey[~m.mask] = 0
            p = os.path.join(room_dir, f"{m.name}.png")
            save_png(p, grey)
            e = os.path.join(room_dir, f"{m.name}.exr")
            save_exr(e, a)
            written += [p, e]
            meta.append({"file": os.path.basename(p), "kind": m.kind, "plane": m.plane,
                         "layer": m.layer, "height_m": None if np.isnan(m.height) else m.height,
                         "shape": list(m.shape), "pixel_m": m.pixel,
                         "origin": m.origin.tolist(), "u": m.u.tolist(), "v": m.v.tolist(),
                         "normal": m.normal.tolist(), "max_votes": float(a.max())})
        if canvas.maps:
            p = os.path.join(room_dir, "contact_sheet.png")
            contact_sheet(p, canvas, maps, top, peaks, found,
                          getattr(run, "label", None) or f"room {run.room}")
            written.append(p)
        j = os.path.join(room_dir, "maps.json")
        atomic_write_text(j, json.dumps({"room": run.room, "joint_scale_max_votes": top,
                                         "maps": meta}, indent=1) + "\n")
        written.append(j)
    return written

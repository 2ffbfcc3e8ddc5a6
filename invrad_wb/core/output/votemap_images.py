"""Vote maps as images for a person to look at (the thesis saved its vote textures too).

For each room: one greyscale PNG per map, all maps scaled jointly to 0-255 (planes and dummy
planes together, so their brightness compares), the raw float votes as EXR, a contact sheet
with every map side by side and the found luminaires marked in red (peaks that the
refinement rejected in blue), and ``maps.json`` describing each map's geometry (origin, u, v,
metres per pixel) so a pixel can be turned into a position.

Image rows are the map's first index (u), columns its second (v).
"""
import json
import os

import numpy as np

from invrad_wb.core.io.atomic import atomic_write_text
from invrad_wb.core.output.images import save_png, save_exr


def _mark(rgb, i, j, colour, r=2):
    h, w, _ = rgb.shape
    for di in range(-r, r + 1):
        for dj in range(-r, r + 1):
            if abs(abs(di) - r) < 1 or abs(abs(dj) - r) < 1:
                ii, jj = int(i) + di, int(j) + dj
                if 0 <= ii < h and 0 <= jj < w:
                    rgb[ii, jj] = colour


def _contact_sheet(tiles, max_width=1600, gap=4):
    """Tiles (h, w, 3) upscaled to about 160 px and packed into rows on white."""
    big = max(max(t.shape[:2]) for t in tiles)
    f = max(1, int(160 // max(big, 1)))
    tiles = [np.repeat(np.repeat(t, f, axis=0), f, axis=1) for t in tiles]
    rows, row, width = [], [], 0
    for t in tiles:
        if row and width + t.shape[1] + gap > max_width:
            rows.append(row)
            row, width = [], 0
        row.append(t)
        width += t.shape[1] + gap
    rows.append(row)
    strips = []
    for r in rows:
        h = max(t.shape[0] for t in r)
        parts = []
        for t in r:
            pad = np.full((h, t.shape[1] + gap, 3), 255, np.uint8)
            pad[:t.shape[0], :t.shape[1]] = t
            parts.append(pad)
        strips.append(np.concatenate(parts, axis=1))
    w = max(s.shape[1] for s in strips)
    out = []
    for s in strips:
        pad = np.full((s.shape[0] + gap, w, 3), 255, np.uint8)
        pad[:s.shape[0], :s.shape[1]] = s
        out.append(pad)
    return np.concatenate(out, axis=0)


def save_vote_maps(result, folder):
    """Write the vote maps of a :class:`LocateResult`; returns the list of files written.

    Every ``room<N>`` folder is written into a private staging folder first and moved into
    ``folder`` only when all are complete: an interrupted run (Ctrl-C, a full disk) leaves
    the previous maps, never a mix. Other files in ``folder`` are left alone.
    """
    import shutil
    import tempfile
    from invrad_wb.core.io.atomic import _prefix, remove_stale
    folder = os.path.abspath(folder)
    os.makedirs(folder, exist_ok=True)
    remove_stale(folder)
    stage = tempfile.mkdtemp(prefix=_prefix(), dir=folder)
    try:
        written = _save_rooms(result, stage)
        names = sorted({os.path.relpath(w, stage).split(os.sep)[0] for w in written})
        for name in names:
            dst = os.path.join(folder, name)
            if os.path.isdir(dst):
                old = tempfile.mkdtemp(prefix=_prefix("old-"), dir=folder)
                os.rmdir(old)
                os.replace(dst, old)
                os.replace(os.path.join(stage, name), dst)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(os.path.join(stage, name), dst)
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
        tiles = []
        found = {}
        for L in run.lights:
            found.setdefault(L.map_index, []).append(L.position)
        for k, (m, a) in enumerate(zip(canvas.maps, maps)):
            grey = np.clip(a * scale, 0, 255).astype(np.uint8)
            grey[~m.mask] = 0
            p = os.path.join(room_dir, f"{m.name}.png")
            save_png(p, grey)
            e = os.path.join(room_dir, f"{m.name}.exr")
            save_exr(e, a)
            written += [p, e]
            rgb = np.repeat(grey[:, :, None], 3, axis=2)
            rgb[~m.mask] = (40, 40, 60)
            for pk in run.peaks:
                if pk.map_index == k:
                    _mark(rgb, pk.ij[0] - 0.5, pk.ij[1] - 0.5, (60, 120, 255), r=1)
            for pos in found.get(k, []):
                d = pos - m.origin
                _mark(rgb, d @ m.u / m.pixel, d @ m.v / m.pixel, (255, 0, 0), r=3)
            tiles.append(rgb)
            meta.append({"file": os.path.basename(p), "kind": m.kind, "plane": m.plane,
                         "layer": m.layer, "height_m": None if np.isnan(m.height) else m.height,
                         "shape": list(m.shape), "pixel_m": m.pixel,
                         "origin": m.origin.tolist(), "u": m.u.tolist(), "v": m.v.tolist(),
                         "normal": m.normal.tolist(), "max_votes": float(a.max())})
        if tiles:
            sheet = _contact_sheet(tiles)
            p = os.path.join(room_dir, "contact_sheet.png")
            save_png(p, sheet)
            written.append(p)
        j = os.path.join(room_dir, "maps.json")
        atomic_write_text(j, json.dumps({"room": run.room, "joint_scale_max_votes": top,
                                         "maps": meta}, indent=1) + "\n")
        written.append(j)
    return written

"""Verification report: how far the achieved illuminance is from the targets, per room.

Metrics follow EN 12464-1 vocabulary and are area weighted over the faces that carry a
target (a face's value is the mean of its three vertices):

* ``Em`` mean, ``Emin``, ``Emax``, uniformity ``U0 = Emin / Em`` (achieved and target);
* ``RMSE %``: root mean square of (achieved - target), relative to the target mean;
* ``MAE %``: mean absolute relative deviation (over faces with a target > 0);
* the largest deviation in lux and percent, and where it is (plane, position in words);
* shade (target 0): the largest and mean achieved illuminance there.

A room with a work plane (virtual faces) gets its work-plane metrics reported separately
from its surfaces. :func:`build_report` writes ``index.html`` (self-contained page; images
next to it), ``rooms.csv``, ``luminaires.csv`` and per room false-colour PNGs: target,
achieved and deviation of every plane "unfolded", and a plan view with the luminaires.
Everything is written atomically.
"""
from dataclasses import dataclass, field
import csv
import html
import io
import os

import numpy as np

from .atomic import atomic_write_text
from . import images as im

DEVIATION_LIMIT = 0.5   # colour scale of the deviation images: -50 % .. +50 %


# ---------------------------------------------------------------------------- words
def describe_plane(plane):
    """'floor', 'ceiling', 'wall facing +x', 'sloped ceiling', 'work plane' ..."""
    n = plane.normal
    if plane.is_virtual:
        return "work plane"
    if n[2] > 0.9:
        return "floor"
    if n[2] < -0.9:
        return "ceiling"
    if n[2] < -0.3:
        return "sloped ceiling"
    if n[2] > 0.3:
        return "sloped floor"
    ax = int(np.argmax(np.abs(n[:2])))
    sign = "+" if n[ax] > 0 else "-"
    return f"wall facing {sign}{'xy'[ax]}"


def describe_point(scene, face, point):
    """Where a point is, in words: 'floor at (2.10, 1.35) m' etc."""
    p = scene.planes[scene.face_plane[face]]
    what = describe_plane(p)
    x, y, z = point
    if what in ("floor", "ceiling", "work plane"):
        return f"{what} at x {x:.2f}, y {y:.2f} m"
    return f"{what} at x {x:.2f}, y {y:.2f}, height {z:.2f} m"


# ---------------------------------------------------------------------------- metrics
def room_metrics(scene, target_vertex_lux, achieved_vertex_lux, faces=None):
    """Target vs achieved metrics over the faces (default: all) that have a target.

    Parameters
    ----------
    scene : Scene
    target_vertex_lux, achieved_vertex_lux : (n,) float64, lux per scene vertex
    faces : (k,) int, optional

    Returns
    -------
    dict (NaN where undefined; ``n_faces`` 0 when no face has a target)
    """
    faces = np.arange(len(scene.faces)) if faces is None else np.asarray(faces, np.int64)
    tgt = np.asarray(target_vertex_lux, np.float64)[scene.faces[faces]]
    ach = np.asarray(achieved_vertex_lux, np.float64)[scene.faces[faces]]
    has = np.all(np.isfinite(tgt), axis=1)
    t = tgt[has].mean(axis=1)
    a = ach[has].mean(axis=1)
    f = faces[has]
    area = scene.face_areas[f]
    out = {"n_faces": int(len(f)), "area_m2": float(area.sum())}
    nan = float("nan")
    shade = t <= 0
    lit = ~shade
    out["shade_area_m2"] = float(area[shade].sum())
    out["shade_max_lux"] = float(a[shade].max()) if shade.any() else nan
    out["shade_mean_lux"] = float(np.average(a[shade], weights=area[shade])) if shade.any() else nan
    if not lit.any():
        for k in ("target_em", "target_emin", "target_emax", "target_u0", "em", "emin", "emax",
                  "u0", "rmse_pct", "mae_pct", "max_dev_lux", "max_dev_pct"):
            out[k] = nan
        out["max_dev_where"] = ""
        out["max_dev_point"] = [nan, nan, nan]
        return out
    tl, al, wl, fl = t[lit], a[lit], area[lit], f[lit]
    out["target_em"] = float(np.average(tl, weights=wl))
    out["target_emin"] = float(tl.min())
    out["target_emax"] = float(tl.max())
    out["target_u0"] = out["target_emin"] / out["target_em"] if out["target_em"] > 0 else nan
    out["em"] = float(np.average(al, weights=wl))
    out["emin"] = float(al.min())
    out["emax"] = float(al.max())
    out["u0"] = out["emin"] / out["em"] if out["em"] > 0 else nan
    dev = al - tl
    out["rmse_pct"] = float(np.sqrt(np.average(dev ** 2, weights=wl)) / out["target_em"] * 100)
    rel = dev / tl
    out["mae_pct"] = float(np.average(np.abs(rel), weights=wl) * 100)
    i = int(np.argmax(np.abs(dev)))
    out["max_dev_lux"] = float(dev[i])
    out["max_dev_pct"] = float(rel[i] * 100)
    c = scene.face_centroids[fl[i]]
    out["max_dev_point"] = [round(float(x), 3) for x in c]
    out["max_dev_where"] = describe_point(scene, fl[i], c)
    return out


# ---------------------------------------------------------------------------- report
@dataclass
class ReportPaths:
    html: str
    rooms_csv: str
    luminaires_csv: str
    images: list = field(default_factory=list)
    metrics: dict = field(default_factory=dict)


_CSV_KEYS = ["room", "name", "part", "n_faces", "area_m2", "target_em", "em", "target_emin",
             "emin", "target_emax", "emax", "target_u0", "u0", "rmse_pct", "mae_pct",
             "max_dev_lux", "max_dev_pct", "max_dev_where", "shade_area_m2", "shade_max_lux",
             "shade_mean_lux", "luminaires"]


def _room_name(room_names, r):
    if room_names is None:
        return f"room {r}"
    try:
        return str(room_names[r])
    except (KeyError, IndexError, TypeError):
        return f"room {r}"


def _fmt(v, digits=1):
    if isinstance(v, (float, np.floating)):
        return "–" if not np.isfinite(v) else f"{v:.{digits}f}"
    return html.escape(str(v))


def build_report(scene, target_vertex_lux, achieved_vertex_lux, luminaires, out_dir,
                 room_names=None, title="invrad verification report", extra=None):
    """Write the report of a forward solve against the targets; returns :class:`ReportPaths`.

    Parameters
    ----------
    scene : Scene
    target_vertex_lux, achieved_vertex_lux : (n,) float64, lux per scene vertex
    luminaires : list of Luminaire (their ``room`` groups them; None = room of nearest face)
    out_dir : folder (created)
    room_names : sequence or dict room id -> name, optional
    extra : dict of str -> str shown under the title (settings, timings...), optional
    """
    os.makedirs(out_dir, exist_ok=True)
    target = np.asarray(target_vertex_lux, np.float64)
    achieved = np.asarray(achieved_vertex_lux, np.float64)
    rooms = [int(r) for r in scene.rooms]
    lum_room = []
    for l in luminaires:
        if l.room is not None:
            lum_room.append(int(l.room))
        else:
            k = int(np.argmin(np.linalg.norm(scene.face_centroids - l.position, axis=1)))
            lum_room.append(int(scene.face_room[k]))
    finite = np.concatenate([target[np.isfinite(target)], achieved[np.isfinite(achieved)]])
    vmax = float(np.percentile(finite, 99.5)) * 1.05 if len(finite) else 1.0
    vmax = max(vmax, 1.0)
    colour = lambda v: im.false_colour(v, 0.0, vmax)  # noqa: E731
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(target > 0, (achieved - target) / target,
                       np.where(target == 0, np.where(achieved > 0.5, 1.0, 0.0), np.nan))
    div = lambda v: im.diverging(v, DEVIATION_LIMIT)  # noqa: E731
    written, rows, sections, metrics_all = [], [], [], {}
    im.save_png(os.path.join(out_dir, "scale_lux.png"), im.colour_bar("viridis", 300, 14))
    im.save_png(os.path.join(out_dir, "scale_dev.png"), im.colour_bar("diverging", 300, 14))
    for r in rooms:
        name = _room_name(room_names, r)
        rf = np.flatnonzero(scene.face_room == r)
        virt = rf[scene.face_virtual[rf]]
        real = rf[~scene.face_virtual[rf]]
        parts = [("all targets", rf)]
        if len(virt):
            parts = [("work plane", virt), ("surfaces", real)]
        room_lums = [(i, l) for i, l in enumerate(luminaires) if lum_room[i] == r]
        mets = {}
        for part, faces in parts:
            m = room_metrics(scene, target, achieved, faces)
            if m["n_faces"] == 0:
                continue
            mets[part] = m
            rows.append({"room": r, "name": name, "part": part, "luminaires": len(room_lums),
                         **{k: m.get(k) for k in _CSV_KEYS if k in m}})
        metrics_all[name] = mets
        planes = [p for p in scene.planes if p.room == r]
        stem = f"room{r}"
        imgs = {}
        for key, vals, fn in (("target", target, colour), ("achieved", achieved, colour),
                              ("deviation", rel, div)):
            img, layout = im.unfold_room(scene, planes, vals, fn)
            path = os.path.join(out_dir, f"{stem}_{key}.png")
            im.save_png(path, img)
            written.append(path)
            imgs[key] = os.path.basename(path)
        horiz = [p for p in planes if p.is_virtual and p.normal[2] > 0.99]
        if not horiz:
            up = [p for p in planes if p.normal[2] > 0.9]
            lowest = min((float(p.origin[2]) for p in up), default=None)
            horiz = [p for p in up if abs(float(p.origin[2]) - lowest) < 0.05] if up else []
        if horiz:
            faces = np.concatenate([p.faces for p in horiz])
            for key, vals, fn in (("plan_achieved", achieved, colour),
                                  ("plan_deviation", rel, div)):
                img, _ = im.plan_view(scene, faces, vals, fn, [l for _, l in room_lums])
                path = os.path.join(out_dir, f"{stem}_{key}.png")
                im.save_png(path, img)
                written.append(path)
                imgs[key] = os.path.basename(path)
        sections.append(_room_html(r, name, mets, planes, imgs, room_lums,
                                   "work plane" if any(p.is_virtual for p in horiz) else "floor"))
    # CSV
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=_CSV_KEYS, extrasaction="ignore")
    w.writeheader()
    for row in rows:
        w.writerow({k: ("" if isinstance(v, float) and not np.isfinite(v) else v)
                    for k, v in row.items()})
    rooms_csv = os.path.join(out_dir, "rooms.csv")
    atomic_write_text(rooms_csv, buf.getvalue())
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["luminaire", "room", "name", "x_m", "y_m", "z_m", "nx", "ny", "nz", "flux_lm",
                "radius_m", "score"])
    for i, l in enumerate(luminaires):
        w.writerow([i + 1, lum_room[i], _room_name(room_names, lum_room[i]),
                    *[f"{x:.4f}" for x in l.position], *[f"{x:.4f}" for x in l.normal],
                    f"{l.flux_lm:g}", f"{l.radius_m:g}",
                    "" if l.score is None else f"{l.score:.4f}"])
    lum_csv = os.path.join(out_dir, "luminaires.csv")
    atomic_write_text(lum_csv, buf.getvalue())
    # HTML
    summary_rows = "".join(
        f"<tr><td>{html.escape(row['name'])}</td><td>{html.escape(row['part'])}</td>"
        f"<td>{row['luminaires']}</td><td>{_fmt(row['target_em'])}</td><td>{_fmt(row['em'])}</td>"
        f"<td>{_fmt(row['u0'], 2)}</td><td>{_fmt(row['rmse_pct'])}</td>"
        f"<td>{_fmt(row['max_dev_pct'])}</td></tr>" for row in rows)
    extra_html = "".join(f"<li><b>{html.escape(str(k))}</b>: {html.escape(str(v))}</li>"
                         for k, v in (extra or {}).items())
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{_CSS}</style></head><body>
<h1>{html.escape(title)}</h1>
<p>{len(luminaires)} luminaire(s) in {len(rooms)} room(s). Achieved = forward solve of the
luminaires (direct light with shadows, plus interreflection where enabled) at the mesh
vertices; metrics are area weighted over the faces that have a target.</p>
{f'<ul class="extra">{extra_html}</ul>' if extra_html else ''}
<h2>Summary</h2>
<table><tr><th>room</th><th>part</th><th>luminaires</th><th>target Em (lx)</th>
<th>achieved Em (lx)</th><th>U0</th><th>RMSE %</th><th>largest dev. %</th></tr>
{summary_rows}</table>
<p class="legend">Illuminance: <img src="scale_lux.png" alt="colour scale"> 0 to
{vmax:.0f} lx (grey: no target). Deviation: <img src="scale_dev.png" alt="deviation scale">
-{DEVIATION_LIMIT * 100:.0f} % (too dark) to +{DEVIATION_LIMIT * 100:.0f} % (too bright);
on shade a lit point shows as too bright.</p>
{''.join(sections)}
<p class="foot">Files: rooms.csv, luminaires.csv. Generated by invrad.</p>
</body></html>
"""
    html_path = os.path.join(out_dir, "index.html")
    atomic_write_text(html_path, page)
    return ReportPaths(html=html_path, rooms_csv=rooms_csv, luminaires_csv=lum_csv,
                       images=written, metrics=metrics_all)


_CSS = """body{font-family:sans-serif;margin:24px;color:#222;max-width:1100px}
h1{font-size:1.5em}h2{border-bottom:1px solid #ccc;padding-bottom:4px;margin-top:32px}
table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 8px;
text-align:right}th{background:#f2f2f2}td:first-child,th:first-child{text-align:left}
figure{display:inline-block;margin:8px 16px 8px 0;vertical-align:top}
figcaption{font-size:.9em;color:#555}img{image-rendering:pixelated}
.legend img{vertical-align:middle;height:14px}.foot{color:#777;font-size:.85em}
.planes{font-size:.9em;color:#444}"""


def _room_html(r, name, mets, planes, imgs, room_lums, plan_what):
    rows = ""
    keys = [("target Em", "target_em", 1), ("achieved Em", "em", 1), ("target Emin",
            "target_emin", 1), ("achieved Emin", "emin", 1), ("target Emax", "target_emax", 1),
            ("achieved Emax", "emax", 1), ("target U0", "target_u0", 2), ("achieved U0", "u0", 2),
            ("RMSE %", "rmse_pct", 1), ("mean abs. dev. %", "mae_pct", 1),
            ("largest dev. (lx)", "max_dev_lux", 1), ("largest dev. %", "max_dev_pct", 1),
            ("shade: max achieved (lx)", "shade_max_lux", 1)]
    parts = list(mets)
    head = "".join(f"<th>{html.escape(p)}</th>" for p in parts)
    for label, key, d in keys:
        rows += f"<tr><td>{label}</td>" + "".join(
            f"<td>{_fmt(mets[p].get(key, float('nan')), d)}</td>" for p in parts) + "</tr>"
    rows += "<tr><td>largest deviation at</td>" + "".join(
        f"<td>{html.escape(mets[p].get('max_dev_where', ''))}</td>" for p in parts) + "</tr>"
    plane_list = ", ".join(f"{k + 1}: {html.escape(describe_plane(p))}"
                           for k, p in enumerate(planes))
    figs = ""
    for key, cap in (("target", "target"), ("achieved", "achieved"),
                     ("deviation", "deviation (achieved vs target)")):
        if key in imgs:
            figs += (f'<figure><img src="{imgs[key]}" alt="{cap}"><figcaption>{cap}, planes'
                     f' unfolded</figcaption></figure>')
    for key, cap in (("plan_achieved", f"plan view: achieved on the {plan_what}, luminaires"
                      " as rings"), ("plan_deviation", f"plan view: deviation on the {plan_what}")):
        if key in imgs:
            figs += f'<figure><img src="{imgs[key]}" alt="{cap}"><figcaption>{cap}</figcaption></figure>'
    lum_rows = "".join(
        f"<tr><td>{k + 1}</td><td>{', '.join(f'{x:.3f}' for x in l.position)}</td>"
        f"<td>{', '.join(f'{x:.2f}' for x in l.normal)}</td><td>{l.flux_lm:g}</td>"
        f"<td>{'' if l.score is None else f'{l.score:.3f}'}</td></tr>"
        for k, (i, l) in enumerate(room_lums))
    return f"""<h2 id="room{r}">{html.escape(name)}</h2>
<table><tr><th>metric</th>{head}</tr>{rows}</table>
<p class="planes">Planes: {plane_list}</p>
{figs}
<h3>Luminaires ({len(room_lums)})</h3>
<table><tr><th>#</th><th>position (m)</th><th>facing</th><th>flux (lm)</th><th>score</th></tr>
{lum_rows}</table>
"""

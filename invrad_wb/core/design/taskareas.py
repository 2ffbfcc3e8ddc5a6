"""Task areas given explicitly: the desks, a table, a counter (EN 12464-1:2021 4.3.3).

Where the spec's work plane lists ``"task_areas"`` (rectangles ``"rect": [x0, y0, x1, y1]``
or polygons ``"polygon": [[x, y], ...]``, metres, in the coordinates of the scene, on the
work plane at its ``height_m``), the room is designed and judged on them instead of on the
room less a border zone (``margin_m``, which the spec then refuses: one or the other):

* **each task area** on its own EN 12464-1 grid (cell centres inside its outline, at most
  ``p = 0.2 * 5^log10(d)`` apart with ``d`` its own longer side, along the room's axes):
  its own Em and U0 against its own requirement (the work plane's ``lux`` / ``u0`` unless
  the area gives its own). It is one more surface grid of the design model (name
  ``'task area: <name>'``, :func:`~.spec.part_name`, gathered with the floor patch under each
  cell as the work plane is), judged on every exact check and ranked by the fast model;
* **the immediate surroundings**: the 0.5 m bands around the task areas, clipped to the
  room, less the task areas (:func:`band_cells` with the distance to the nearest task area
  in ``(0, 0.5]``), each area's from its own Em (EN 12464-1:2021 4.3.3, Table 3): where the
  areas ask for different Table-3 levels (desks at 500 lx, a counter at 300 lx), one grid
  per level (``'surroundings (desks)'``), each cell in the band of its nearest task area
  (:func:`surroundings_levels`); one ``'surroundings'`` grid where all share a level;
* **the background area**: beyond the surroundings, up to 3 m further (distance in
  ``(0.5, 3.5]``), clipped to the room, split by the same levels (``'background
  (desks)'``): one third of its surroundings' Em, U0 0.10 (:mod:`.background`), or what the
  spec's ``"background"`` asks.

The room's work-plane cells (the first ``n`` receivers of the design model, which the
search's count range, its fast ranking and the report's plan use) are the union of the
task areas' cells; the search judges no U0 over that union (two task areas at different
levels are not one task), only each area's own.
"""
from dataclasses import replace

import numpy as np

from invrad_wb.core.design import en12464
from invrad_wb.core.design.background import background_requirement, band_grid, has_headroom
from invrad_wb.core.design.cylindrical import SURROUNDINGS_U0, surroundings_lux
from invrad_wb.core.design.room import in_polygon
from invrad_wb.core.design.spec import SurfaceRequirement
from invrad_wb.core.geometry.outline import inside_outline
from invrad_wb.core.geometry.polygon import (crossing_t, edges_3d, polygon_edges,
                                             segments_cross)
from invrad_wb.core.model.targets import WORK_PLANE_HEADROOM_M, distance_to_segments

#: the immediate surroundings' width around a task area (EN 12464-1:2021 4.3.3), m
SURROUNDINGS_M = 0.5
#: the background area's least width beyond the surroundings (EN 12464-1:2021 4.3.3), m
BACKGROUND_M = 3.0
#: the bands' cells are at most this on a side (two rows across the 0.5 m band)
BAND_SPACING_M = 0.25
#: each band cell's share of the band is counted on SUB x SUB samples
SUB = 8
#: a task area's outline may lie this far outside the floor outline (mesh rounding), m
OUTSIDE_TOL_M = 1e-3


def area_distance(areas, xy):
    """(k,) distance (m) of plan points ``xy`` (k, 2) to the nearest task area: 0 inside
    one, else to its outline."""
    return nearest_area(areas, xy)[0]


def nearest_area(areas, xy, reach=np.inf):
    """``(d, i)``: (k,) distance (m) of plan points ``xy`` (k, 2) to the nearest task area
    (0 inside one, else to its outline) and (k,) that area's index (the first of areas at
    one distance). Each area is measured only at the points within ``reach`` of its
    bounding box (a band around 28 desks in a large room: a few of them near each point);
    a point beyond ``reach`` of every area gets ``inf`` and ``-1``."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    d = np.full(len(xy), np.inf)
    idx = np.full(len(xy), -1)
    for i, a in enumerate(areas):
        p = np.asarray(a.polygon, dtype=np.float64)
        lo, hi = p.min(axis=0) - reach, p.max(axis=0) + reach
        sel = np.flatnonzero(np.all((xy >= lo) & (xy <= hi), axis=1))
        if not len(sel):
            continue
        q = xy[sel]
        di = distance_to_segments(np.c_[q, np.zeros(len(q))], edges_3d(polygon_edges(p)))
        di[in_polygon(p, q)] = 0.0
        better = di < d[sel]
        d[sel[better]] = di[better]
        idx[sel[better]] = i
    return d, idx


def near_areas(areas, reach):
    """``near(centres, r)`` for :func:`~.background.band_grid`: the cells whose centre lies
    within ``reach + r`` of some task area's bounding box."""
    boxes = np.array([np.r_[np.min(a.polygon, axis=0), np.max(a.polygon, axis=0)]
                      for a in areas], dtype=np.float64)

    def near(centres, r):
        g = reach + r
        return np.any((centres[:, None, 0] >= boxes[None, :, 0] - g)
                      & (centres[:, None, 1] >= boxes[None, :, 1] - g)
                      & (centres[:, None, 0] <= boxes[None, :, 2] + g)
                      & (centres[:, None, 1] <= boxes[None, :, 3] + g), axis=1)
    return near


def outline_breach(outline, polygon, tol=OUTSIDE_TOL_M):
    """Where a plan polygon leaves a closed outline (segments (k, 2, 2), even-odd), found
    exactly: ``None`` where it lies within (its edges may run along the outline), else
    ``(point, crosses)``: the point where an edge crosses the outline (``crosses``) or,
    for a polygon wholly outside, one of its corners. Each edge is cut at every point it
    meets the outline (crossings, outline corners on it, within ``tol`` m); between two
    such points it is wholly inside or outside, told by the middle of the stretch."""
    out = np.asarray(outline, dtype=np.float64).reshape(-1, 2, 2)
    seg3 = edges_3d(out)
    corners = out.reshape(-1, 2)
    hit = None
    for a, b in polygon_edges(polygon):
        ab = b - a
        ll = float(ab @ ab)
        if ll <= 0:
            continue
        ts = [0.0, 1.0]
        for c, d in out:
            if segments_cross(a, b, c, d, touch=False, tol=tol):
                ts.append(crossing_t(a, b, c, d))
        t = (corners - a) @ ab / ll
        near = np.linalg.norm(a + np.clip(t, 0, 1)[:, None] * ab - corners, axis=1) <= tol
        ts.extend(np.clip(t[near], 0.0, 1.0))
        ts = np.unique(np.round(ts, 12))
        mids = a + (0.5 * (ts[:-1] + ts[1:]))[:, None] * ab
        gone = ~inside_outline(out, mids) & (
            distance_to_segments(np.c_[mids, np.zeros(len(mids))], seg3) > tol)
        for i in np.flatnonzero(gone):
            contact = [ts[i]] if ts[i] > 0 or _on(a, seg3, tol) else []
            contact += [ts[i + 1]] if ts[i + 1] < 1 or _on(b, seg3, tol) else []
            if contact:
                return a + contact[0] * ab, True
            hit = hit or (a, False)
    return hit


def _on(p, seg3, tol):
    return bool(distance_to_segments(np.r_[p, 0.0][None], seg3)[0] <= tol)


def check_task_areas(scene, spec, names):
    """Refuse a task area before any computation: one that reaches outside its room's
    outer outline (a column inside the area is no fault: its cells are left out), or one
    with no point where the work plane has head room; a one-line SettingsError naming the
    spec key, the room, the task area and the point or the heights."""
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.errors import SettingsError
    for room, name in names.items():
        rs = spec.room_spec(room, name)
        wp = None if rs is None else rs.work_plane
        areas = getattr(wp, "task_areas", ()) if wp is not None else ()
        if not areas:
            continue
        label = name or f"room {room}"
        droom = DesignRoom(scene, room, label)
        outer = droom.outer_outline()
        for a in areas:
            key = f"{spec.source}: rooms.{rs.key}.work_plane.task_areas.{a.name}"
            out = outline_breach(outer, a.polygon)
            if out is not None:
                (x, y), crosses = out
                raise SettingsError(
                    f"{key}: crosses the outline of {label} at ({x:.2f}, {y:.2f})" if crosses
                    else f"{key}: lies outside {label} (its corner ({x:.2f}, {y:.2f}) is"
                    " beyond the room's outline)")
            if task_cells(droom, wp.height_m, a) is None:
                zc, _ = droom.ceiling_at(np.asarray(a.polygon, dtype=np.float64))
                top = np.nanmax(zc) - droom.floor_z if np.isfinite(zc).any() else 0.0
                raise SettingsError(
                    f"{key}: no head room over it: the work plane at {wp.height_m:.2f} m needs"
                    f" the ceiling above {wp.height_m + WORK_PLANE_HEADROOM_M:.2f} m, it is at"
                    f" most {top:.2f} m over the area")


def task_cells(droom, height_m, area, headroom=True):
    """A task area's EN 12464-1 calculation points: (points (j, 3), normals (j, 3)
    facing up, weights (j,) m^2), cell centres inside its outline and the room (with head
    room), at most ``p`` of its own longer side apart along the room's axes. A thin or
    small area gets a finer grid until at least one centre falls inside it. With
    ``headroom`` False, the cells regardless of the ceiling (the part without head room
    measured against them)."""
    st_poly = droom.to_plan(np.asarray(area.polygon, dtype=np.float64))
    lo, hi = st_poly.min(axis=0), st_poly.max(axis=0)
    size = np.maximum(hi - lo, 1e-9)
    ns, nt = en12464.grid_counts(size[0], size[1])
    for _ in range(6):
        ds, dt = size[0] / ns, size[1] / nt
        s = lo[0] + (np.arange(ns) + 0.5) * ds
        t = lo[1] + (np.arange(nt) + 0.5) * dt
        xy = droom.to_world(np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2))
        keep = (in_polygon(area.polygon, xy) & (droom.wall_distance(xy) >= -OUTSIDE_TOL_M)
                & (has_headroom(droom, xy, height_m) if headroom else True))
        if keep.any():
            break
        ns, nt = 2 * ns, 2 * nt
    k = int(keep.sum())
    if not k:
        return None
    pts = np.c_[xy[keep], np.full(k, droom.floor_z + height_m)]
    return pts, np.tile([0.0, 0.0, 1.0], (k, 1)), np.full(k, ds * dt)


def band_cells(droom, height_m, areas, d0, d1, spacing, only=None):
    """Cells of the work plane whose distance to the nearest task area lies in
    ``(d0, d1]``, clipped to the room's outline and to where the work plane has head room:
    (points (j, 3), normals (j, 3) facing up, weights (j,) m^2: each cell's share of the
    band counted on :data:`SUB` x :data:`SUB` samples), or None where none remains. A
    cell's point is its in-band sample nearest their centroid (in the band for sure).
    ``only`` (indices into ``areas``): the part of the band nearest to those areas (their
    own surroundings where other areas ask for another level)."""
    p = min(en12464.grid_spacing(float(np.max(droom.size))), spacing)
    reach = d1 + 1e-6
    mine = None if only is None else np.asarray(sorted(only))

    def in_band(xy):
        d, i = nearest_area(areas, xy, reach)
        ok = (d > d0 + 1e-9) & (d <= d1 + 1e-9)
        return ok if mine is None else ok & np.isin(i, mine)
    return band_grid(droom, height_m, p, SUB, in_band,
                     near_areas(areas if mine is None else [areas[i] for i in mine], reach))


def surroundings_levels(areas, lux):
    """The task areas grouped by the Table-3 level of their immediate surroundings
    (EN 12464-1:2021 4.3.3: each task area's from its own Em): a list of ``(key suffix,
    indices, task lux)``, the highest level first; one group (suffix ``''``) where all
    share a level, else each named after its areas ``' (desks)'``."""
    groups = {}
    for i, x in enumerate(lux):
        groups.setdefault(surroundings_lux(x), []).append(i)
    out = []
    for level in sorted(groups, reverse=True):
        idx = groups[level]
        names = [areas[i].name for i in idx]
        words = ", ".join(names) if len(names) <= 3 else f"{names[0]} and {len(names) - 1} more"
        out.append(("" if len(groups) == 1 else f" ({words})", idx, max(lux[i] for i in idx)))
    return out


def area_requirement(area, req):
    """A task area's :class:`~.spec.SurfaceRequirement`: its own lux / u0, else the work
    plane's."""
    lux = req.lux if area.lux is None else area.lux
    u0 = req.u0 if area.u0 is None else area.u0
    own = area.lux is not None or area.u0 is not None
    return SurfaceRequirement(lux, u0, ("spec (this task area)" if own else req.source)
                              + f"; task area {area.area_m2:.2f} m2")


def prepare(rs, droom, req, surfaces, rd):
    """The design model's grids of a room whose work plane lists task areas: returns
    ``(points, rs, search_req)``: the work-plane points (the union of the task areas'
    cells), the room spec with a requirement per task area, for the immediate
    surroundings and for the background (their grids added to ``surfaces``, judged and
    searched like the walls), and the requirement the search takes for the union
    (the lowest task Em, no U0 over the union: each area's own is judged)."""
    reqs = dict(rs.surfaces)
    pts = []
    lux = []
    for a in req.task_areas:
        cells = task_cells(droom, req.height_m, a)     # not None: check_task_areas
        whole = task_cells(droom, req.height_m, a, headroom=False)[2].sum()
        if cells[2].sum() < whole - 1e-6:
            rd.notes.append(f"task area {a.name!r}: judged on {cells[2].sum():.2f} of"
                            f" {whole:.2f} m2 (the rest has no head room above the work"
                            " plane)")
        surfaces[a.part] = cells
        q = reqs[a.part] = area_requirement(a, req)
        pts.append(cells[0])
        lux.append(q.lux)
    given = getattr(rs, "background", None)
    levels = surroundings_levels(req.task_areas, lux)
    bg_any = False
    for suffix, idx, task_lux in levels:
        only = None if len(levels) == 1 else idx
        band = band_cells(droom, req.height_m, req.task_areas, 0.0, SURROUNDINGS_M,
                          BAND_SPACING_M, only)
        if band is None:
            rd.notes.append(f"immediate surroundings{suffix}: the task areas leave no floor"
                            " around them: not computed")
        else:
            surfaces["surroundings" + suffix] = band
            reqs["surroundings" + suffix] = SurfaceRequirement(
                surroundings_lux(task_lux), SURROUNDINGS_U0,
                "EN 12464-1:2021 Table 3 (0.5 m band around the task areas"
                + (f" nearest to {suffix[2:-1]}, of their Em {task_lux:g} lx)" if suffix
                   else ")"))
        q = background_requirement(given, task_lux)
        if q is None:
            continue
        bg = band_cells(droom, req.height_m, req.task_areas, SURROUNDINGS_M,
                        SURROUNDINGS_M + BACKGROUND_M, 0.5 * BACKGROUND_M, only)
        if bg is not None:
            bg_any = True
            surfaces["background" + suffix] = bg
            reqs["background" + suffix] = q
    if given is False:
        rd.background_words = "no limit (the spec's \"background\" is null): not judged"
    elif not bg_any:
        rd.background_words = ("none: the task areas and their 0.5 m immediate"
                               " surroundings cover the room")
    else:
        rd.background_words = None
    search_req = replace(req, lux=min(lux), u0=0.0, task_areas=())
    return np.concatenate(pts), replace(rs, surfaces=reqs), search_req

"""The background area of a task area (EN 12464-1:2021 4.3.3 / 4.3.4).

EN 12464-1:2021 asks for light beyond the task area and its immediate surroundings (the
0.5 m band of :mod:`.cylindrical`): the *background area*, "a border at least 3 m wide
adjacent to the immediate surrounding area within the limits of the space", lit to a
maintained illuminance of at least one third of the immediate surrounding area's
(:func:`background_lux`) with ``U0 >= 0.10``.

**Where.** With the task area the room less its border zone of ``margin_m`` (measured
from the walls and from the columns, as the task area and its surroundings are), the
surroundings are the cells whose distance ``d`` to the walls lies in
``[margin_m - 0.5, margin_m)`` and the background those with ``d`` in
``[margin_m - 0.5 - BAND_M, margin_m - 0.5)`` (:data:`BAND_M` = 3 m, the standard's
least width), clipped to the room's outline (an L, around its columns) and to where the
work plane has head room. Where the room ends within 3 m only what remains is background;
where nothing remains (the usual task area of a whole room, the room less a 0.5 m border:
its surroundings fill the border) there is no background area, and the report says so.
Cells are on the work plane (its height), facing up, at most the EN 12464-1 grid spacing
of the room and at most half the band's width apart (two rows across it at least); each
is weighted by the area of its part in the band (counted on :data:`SUB` x :data:`SUB`
samples) and judged at the sample of that part nearest its centroid.

**Required.** One third of the surroundings' Em (Table 3, :func:`.cylindrical.surroundings_lux`)
and U0 0.10 (:data:`BACKGROUND_U0`) by default, for every room whose task area leaves a
background; the spec's ``"background": {"lux", "u0"}`` may ask for more (never less: the
minimums are raised to) and ``"background": null`` drops the item ("no limit").

The band is one more surface grid of the design model (name ``'background'``, gathered
with the floor patch under each cell as the work plane is): judged by every exact check,
served by the dimming level and by the per-group dimming programme like the walls, left
out of the fast model's ranking as the surroundings are (:data:`.search.EXACT_ONLY`).
"""
import math

import numpy as np

from invrad_wb.core.design import en12464
from invrad_wb.core.design.cylindrical import BAND_M as SURROUNDINGS_M
from invrad_wb.core.design.cylindrical import surroundings_lux
from invrad_wb.core.model.targets import WORK_PLANE_HEADROOM_M

#: EN 12464-1:2021 4.3.3: the background area's least width beyond the surroundings (m)
BAND_M = 3.0
#: ... its maintained illuminance: at least this share of the surroundings' Em
SHARE = 1.0 / 3.0
#: ... and its uniformity
BACKGROUND_U0 = 0.10
#: background cells are at least this on a side (a thin remainder still gets rows)
MIN_SPACING_M = 0.1
#: each cell's share of the band is counted on SUB x SUB samples
SUB = 10
SOURCE = ("EN 12464-1:2021 4.3.3 (a band of 3 m beyond the immediate surroundings:"
          " 1/3 of their Em, U0 0.10)")
#: words where a room has no background area because its surroundings fill the border
NONE_LEFT = ("none: the task area and its 0.5 m immediate surroundings cover the room"
             " (no floor is left beyond them)")


def background_lux(task_lux):
    """The background area's least Em (lx) for a task's Em: one third of the immediate
    surroundings' (EN 12464-1:2021 Table 3 and 4.3.3); e.g. 500 lx -> 300 -> 100 lx."""
    return surroundings_lux(task_lux) * SHARE


def band_limits(margin_m, width_m=BAND_M):
    """``(d0, d1)``: the background's distances to the walls, ``d0 <= d < d1``, of a
    task area with a border zone of ``margin_m``; None where the surroundings reach the
    walls (nothing beyond them)."""
    d1 = float(margin_m) - SURROUNDINGS_M
    if d1 <= 1e-9:
        return None
    return max(0.0, d1 - float(width_m)), d1


def background_grid(droom, height_m, margin_m, width_m=BAND_M):
    """Cells of the background area of a task area with a border zone of ``margin_m``
    (see the module docstring): (points (j, 3), normals (j, 3) facing up, weights (j,)
    m^2), or None where none remains in the room."""
    lim = band_limits(margin_m, width_m)
    if lim is None:
        return None
    d0, d1 = lim
    p = min(en12464.grid_spacing(float(np.max(droom.size))),
            max(0.5 * (d1 - d0), MIN_SPACING_M))

    def in_band(xy):
        d = droom.wall_distance(xy)
        return (d >= d0 - 1e-9) & (d < d1 - 1e-9)
    return band_grid(droom, height_m, p, SUB, in_band)


def has_headroom(droom, xy, height_m):
    """(k,) bool: the work plane at ``height_m`` has head room over plan points ``xy``
    (:data:`~invrad_wb.core.model.targets.WORK_PLANE_HEADROOM_M` under the ceiling)."""
    zc, _ = droom.ceiling_at(xy)
    return np.nan_to_num(zc, nan=np.inf) >= droom.floor_z + height_m + WORK_PLANE_HEADROOM_M


def band_grid(droom, height_m, spacing, sub, in_band, near=None):
    """The cells of a band of the work plane (the background here, a task area's
    surroundings and background in :mod:`.taskareas`): the room's bounding rectangle cut
    in cells at most ``spacing`` apart, each cell's share of the band counted on ``sub`` x
    ``sub`` samples (the weights add up to the band's area: a coarse grid's cell centres
    alone miss or overcount a band edge) where ``in_band(xy)`` ((k,) bool of world plan
    points (k, 2)) holds, within the room's outline and with head room. Each cell is
    judged at its in-band sample nearest their centroid (in the band for sure).
    ``near(centres, r)``, optional: (c,) bool of the cells worth sampling from their world
    centres (c, 2) and half-diagonal ``r`` (a band around a few task areas in a large
    room). Returns (points (j, 3), normals (j, 3) facing up, weights (j,) m^2), or None
    where no cell has a part in the band."""
    ns = max(1, int(math.ceil(droom.size[0] / spacing - 1e-9)))
    nt = max(1, int(math.ceil(droom.size[1] / spacing - 1e-9)))
    ds, dt = droom.size[0] / ns, droom.size[1] / nt
    cs, ct = (c.reshape(-1) for c in np.meshgrid(np.arange(ns), np.arange(nt), indexing="ij"))
    if near is not None:
        sel = near(droom.to_world(np.c_[(cs + 0.5) * ds, (ct + 0.5) * dt]),
                   0.5 * math.hypot(ds, dt))
        cs, ct = cs[sel], ct[sel]
    u = (np.arange(sub) + 0.5) / sub
    us, ut = (c.reshape(1, -1) for c in np.meshgrid(u, u, indexing="ij"))
    st = np.stack([(cs[:, None] + us) * ds, (ct[:, None] + ut) * dt], axis=-1)  # (c, k2, 2)
    xy = droom.to_world(st.reshape(-1, 2))
    inb = in_band(xy)
    inb[inb] &= droom.inside(xy[inb])
    inb[inb] &= has_headroom(droom, xy[inb], height_m)
    inb = inb.reshape(len(cs), sub * sub)
    n_in = inb.sum(axis=1)
    cells = np.flatnonzero(n_in)
    if not len(cells):
        return None
    xy = xy.reshape(len(cs), sub * sub, 2)[cells]
    inb = inb[cells]
    cen = np.einsum("cs,csj->cj", inb, xy) / n_in[cells, None]
    far = np.where(inb, np.linalg.norm(xy - cen[:, None, :], axis=2), np.inf)
    pick = xy[np.arange(len(cells)), np.argmin(far, axis=1)]
    m = len(cells)
    pts = np.c_[pick, np.full(m, droom.floor_z + height_m)]
    return pts, np.tile([0.0, 0.0, 1.0], (m, 1)), n_in[cells] / (sub * sub) * ds * dt


def background_requirement(given, task_lux):
    """The background's :class:`~.spec.SurfaceRequirement` for a task of ``task_lux``:
    ``given`` is the room spec's ``background`` (None: the EN 12464-1 default; False:
    ``null`` in the spec, no limit, returns None; ``(lux or None, u0)``: as the spec asks,
    raised to the default where below it)."""
    from invrad_wb.core.design.spec import SurfaceRequirement
    if given is False:
        return None
    lo = background_lux(task_lux)
    if given is None:
        return SurfaceRequirement(lo, BACKGROUND_U0, SOURCE)
    lux, u0 = given
    lux = lo if lux is None else lux
    raised = lux < lo - 1e-9 or u0 < BACKGROUND_U0 - 1e-9
    return SurfaceRequirement(max(lux, lo), max(u0, BACKGROUND_U0),
                              "spec, raised to the EN 12464-1:2021 4.3.3 minimum" if raised
                              else "spec")


def with_background(rs, droom, req, surfaces, rd):
    """The room spec ``rs`` with its background area's requirement where the task area
    (``req``: its lux, height and border zone) leaves one and the spec sets a limit; its
    grid joins ``surfaces`` (evaluated and searched like the walls). Where there is none,
    ``rd.background_words`` says why (the report's and the JSON's words)."""
    from dataclasses import replace
    q = background_requirement(getattr(rs, "background", None), req.lux)
    if q is None:
        rd.background_words = "no limit (the spec's \"background\" is null): not judged"
        return rs
    band = background_grid(droom, req.height_m, req.margin_m)
    if band is None:
        rd.background_words = NONE_LEFT if req.margin_m > 1e-9 else (
            "none: the task area covers the whole room (border zone 0)")
        return rs
    rd.background_words = None
    surfaces["background"] = band
    return replace(rs, surfaces={**rs.surfaces, "background": q})

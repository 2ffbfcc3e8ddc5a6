"""Cylindrical illuminance Ez, modelling, and the task area's immediate surroundings
(EN 12464-1:2021 4.6.2 and 4.3.3 / Table 3).

**Ez.** The mean cylindrical illuminance at a point is the vertical illuminance averaged
over all horizontal directions. It is computed on the task area's grid cells (the work
plane's cells, its border zone left out) lifted to the requirement's height (1.2 m by
default, a seated person's face), maintained (x maintenance factor):

* direct light, exactly for a point source: averaging ``I cos(theta) / d^2`` over the
  horizontal normals gives ``Ez = I(direction) sin(gamma) / (pi d^2)`` (``gamma`` the
  angle of the ray with the vertical). Each luminaire's light is computed by the design
  model's direct-light routine on a vertical receiver facing it horizontally
  (``I sin(gamma) / d^2``, its photometry, C0 orientation and occlusion included) and
  divided by pi. A disk luminaire's quadrature points are seen by the receiver facing its
  centre (exact for a point source, a small error for a large disk close by);
* interreflected light, from the design model's radiosity (the room's patches' exitance
  and the point-to-patch form factors; a point in the air belongs to no plane, so every
  patch counts, the floor too; occlusion: in a room with occluders (pillars, partitions,
  re-entrant walls) the point's own, by segments to the patches' samples, else the floor
  patch's under it, as the work plane is gathered): the vertical illuminance in
  :data:`N_DIRECTIONS` horizontal directions, averaged. The room surfaces' light is diffuse
  and spread, so the discrete average is close to the continuous one (8 directions:
  within about 1 % for a source well off the point's vertical; the discrete mean of
  ``max(cos, 0)`` is 0.302 to 0.328 of the exact ``1 / pi`` = 0.318 for a single small
  source).

Judged: ``Em,z >= lux`` and ``U0,z = Emin,z / Em,z >= u0``. The modelling ratio Ez / Eh
(Eh the horizontal illuminance at the same points) is reported against EN 12464-1's
recommended 0.30 to 0.60: a note, not a verdict.

**Immediate surroundings.** A band of :data:`BAND_M` (0.5 m) around the task area: with
the task area the room less its border zone of ``margin_m``, the cells of the work plane
whose distance to the walls lies in ``[margin_m - BAND_M, margin_m)``. Its grid spacing is
the task area's, at most :data:`BAND_SPACING_M` so that the band holds at least two rows
of cells. Required (Table 3): ``Em`` one step below the task's (:func:`surroundings_lux`)
and ``U0 >= 0.40``. The band is evaluated by the design model as one more surface grid
(name ``'surroundings'``, facing up, gathered with the floor patch under each cell as the
work plane is); every exact check of the search judges it and the dimming level serves
its Em, as for the walls; the fast model's ranking leaves it out
(:data:`~.search.EXACT_ONLY`: it follows the work plane, and its per-point corrected fast
figures turned away layouts that comply).
"""
import math

import numpy as np

from invrad_wb.core.design import en12464
from invrad_wb.core.design.openings import luminous_samples
from invrad_wb.core.forward.direct import direct_illuminance
from invrad_wb.core.model.targets import WORK_PLANE_HEADROOM_M

#: horizontal directions of the interreflected part of Ez
N_DIRECTIONS = 8
#: EN 12464-1:2021 4.6.2: recommended range of the modelling ratio Ez / Eh
MODELLING_RANGE = (0.30, 0.60)
#: width of the immediate surroundings around the task area (EN 12464-1:2021 4.3.3)
BAND_M = 0.5
#: the surroundings' cells are at most this on a side (two rows across the band)
BAND_SPACING_M = 0.25
#: EN 12464-1:2021 4.3.3 and Table 3: the immediate surroundings' uniformity
SURROUNDINGS_U0 = 0.40
#: EN 12464-1:2021 Table 3: task Em (lx) -> immediate surroundings Em (lx); a task at or
#: below 150 lx: the task's own value
TABLE_3 = ((750.0, 500.0), (500.0, 300.0), (300.0, 200.0), (200.0, 150.0), (150.0, 150.0))
SURROUNDINGS_SOURCE = "EN 12464-1:2021 Table 3 (0.5 m band around the task area)"


def surroundings_lux(task_lux):
    """The immediate surroundings' Em (lx) for a task's Em (EN 12464-1:2021 Table 3).

    750 lx and more -> 500, 500 -> 300, 300 -> 200, 200 -> 150, 150 -> 150, less -> the
    task's own value. A task value between two rows takes the row above it (400 lx ->
    300 lx, as 500 lx does): never less than the standard asks for its level."""
    task_lux = float(task_lux)
    rows = [s for t, s in sorted(TABLE_3) if t >= task_lux - 1e-9]
    return min(task_lux, rows[0] if rows else TABLE_3[0][1])


def surroundings_grid(droom, height_m, margin_m):
    """Cells of the immediate surroundings (see the module docstring): (points (j, 3),
    normals (j, 3) facing up, weights (j,) m^2), or None where the task area has no band
    around it (no border zone)."""
    if margin_m <= 1e-9:
        return None
    ns, nt = en12464.grid_counts(*droom.size)
    ns = max(ns, int(math.ceil(droom.size[0] / BAND_SPACING_M - 1e-9)))
    nt = max(nt, int(math.ceil(droom.size[1] / BAND_SPACING_M - 1e-9)))
    ds, dt = droom.size[0] / ns, droom.size[1] / nt
    s = (np.arange(ns) + 0.5) * ds
    t = (np.arange(nt) + 0.5) * dt
    st = np.stack(np.meshgrid(s, t, indexing="ij"), axis=-1).reshape(-1, 2)
    xy = droom.to_world(st)
    d = droom.wall_distance(xy)
    keep = droom.inside(xy) & (d >= max(0.0, margin_m - BAND_M) - 1e-9) & (d < margin_m - 1e-9)
    zc, _ = droom.ceiling_at(xy)
    keep &= np.nan_to_num(zc, nan=np.inf) >= droom.floor_z + height_m + WORK_PLANE_HEADROOM_M
    if not keep.any():
        return None
    k = int(keep.sum())
    pts = np.c_[xy[keep], np.full(k, droom.floor_z + height_m)]
    return pts, np.tile([0.0, 0.0, 1.0], (k, 1)), np.full(k, ds * dt)


class CylindricalGrid:
    """Ez and Eh of any installation at a room's cylindrical-illuminance points.

    Parameters
    ----------
    model : evaluate.RoomModel (its radiosity, occluders and maintenance factor)
    points : (k, 3) float64, the points (task-area cells at the requirement's height)
    requirement : dict {'lux', 'u0', 'height_m'}
    """

    def __init__(self, model, points, requirement):
        self.model = model
        self.req = dict(requirement)
        self.points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        k = len(self.points)
        a = 2.0 * np.pi * np.arange(N_DIRECTIONS) / N_DIRECTIONS
        dirs = np.c_[np.cos(a), np.sin(a), np.zeros(N_DIRECTIONS)]
        # receivers: N_DIRECTIONS vertical ones per point, then one facing up
        pts = np.concatenate([np.tile(self.points, (N_DIRECTIONS, 1)), self.points])
        nrm = np.concatenate([np.repeat(dirs, k, axis=0), np.tile([0.0, 0.0, 1.0], (k, 1))])
        under = np.tile(model.floor_patches(self.points), N_DIRECTIONS + 1)
        # a room with occluders (pillars, partitions, re-entrant walls): each point's own
        # visibility, by segments from it to the patches' samples; the floor patch under
        # a point beside a pillar sees past it what the point does not
        self._op = model.air_gather(pts, nrm, under, own_visibility=model.bvh is not None)

    def gather(self, exitance):
        """Interreflected (ez (k,), eh (k,)) lux for patch exitances ``exitance`` (P,)
        (:class:`~.evaluate.AirGather`: a point in the air belongs to no plane, every
        patch counts; occlusion is the point's own where the room has occluders, else
        the visibility row of the floor patch under it, the same in a convex room)."""
        k = len(self.points)
        e = self._op(exitance)
        return e[:N_DIRECTIONS * k].reshape(N_DIRECTIONS, k).mean(axis=0), e[N_DIRECTIONS * k:]

    def direct(self, luminaires):
        """Direct (ez (k,), eh (k,)) lux of the new installation (not maintained)."""
        m, k = self.model, len(self.points)
        ez, eh = np.zeros(k), np.zeros(k)
        if not luminaires:
            return ez, eh
        occl = m.bvh is not None
        luminaires = luminous_samples(luminaires)
        for lum in luminaires:
            h = lum.position[None, :2] - self.points[:, :2]
            r = np.linalg.norm(h, axis=1)
            ok = r > 1e-9                       # straight below: sin(gamma) = 0
            if ok.any():
                nrm = np.zeros((int(ok.sum()), 3))
                nrm[:, :2] = h[ok] / r[ok, None]
                ez[ok] += direct_illuminance(self.points[ok], nrm, [lum], bvh=m.bvh,
                                             occlusion=occl, backend=m.backend) / np.pi
        eh += direct_illuminance(self.points, np.tile([0.0, 0.0, 1.0], (k, 1)), luminaires,
                                 bvh=m.bvh, occlusion=occl, backend=m.backend)
        return ez, eh

    def indirect(self, luminaires, covering=None):
        """Interreflected (ez (k,), eh (k,)) lux of the new installation (``covering``:
        :meth:`.evaluate.RoomModel.solve`)."""
        m, k = self.model, len(self.points)
        if not luminaires:
            return np.zeros(k), np.zeros(k)
        return self.gather(m.solve(luminaires, covering))

    def evaluate(self, luminaires, covering=None):
        """Maintained (ez (k,), eh (k,)) lux of ``luminaires`` at the points (``covering``:
        :meth:`.evaluate.RoomModel.solve`)."""
        dz, dh = self.direct(luminaires)
        iz, ih = self.indirect(luminaires, covering)
        return self.model.mf * (dz + iz), self.model.mf * (dh + ih)


def figures(ez, eh):
    """{'em_lux', 'emin_lux', 'u0', 'eh_lux', 'modelling', 'modelling_min',
    'modelling_max'} of maintained Ez and Eh at the points."""
    em = float(np.mean(ez))
    ehm = float(np.mean(eh))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(eh > 1e-9, ez / np.maximum(eh, 1e-12), np.nan)
    return {"em_lux": em, "emin_lux": float(np.min(ez)),
            "u0": float(np.min(ez) / em) if em > 0 else 0.0, "eh_lux": ehm,
            "modelling": em / ehm if ehm > 0 else None,
            "modelling_min": None if np.isnan(ratio).all() else float(np.nanmin(ratio)),
            "modelling_max": None if np.isnan(ratio).all() else float(np.nanmax(ratio))}


def complies(fig, requirement):
    """Ez judged: Em,z >= lux and U0,z >= u0."""
    return bool(fig["em_lux"] >= requirement["lux"] - 1e-9
                and fig["u0"] >= requirement["u0"] - 1e-9)


def modelling_note(fig):
    """A sentence on the modelling ratio (EN 12464-1:2021 4.6.2), or None."""
    r = fig.get("modelling")
    if r is None:
        return None
    lo, hi = MODELLING_RANGE
    where = ("within" if lo <= r <= hi else "below" if r < lo else "above")
    # as many decimals as it takes for a ratio outside the range not to print as its
    # bound ("0.30 is below the recommended 0.30" for 0.298)
    d = 2
    while d < 4 and ((r < lo and round(r, d) >= lo) or (r > hi and round(r, d) <= hi)):
        d += 1
    return (f"modelling Ez/Eh {r:.{d}f} (points {fig['modelling_min']:.2f} to"
            f" {fig['modelling_max']:.2f}) is {where} the recommended {lo:.2f} to {hi:.2f}"
            " (EN 12464-1:2021 4.6.2; a recommendation, not judged)")

"""Candidate luminaire layouts of a room: rows and columns along the room's axes.

A *grid* has ``ns x nt`` positions along the room's length and width. Along a side of length
``L`` with ``n`` luminaires the spacing is ``s = L / (n - 1 + 2 f)`` and the first luminaire
sits ``f * s`` from the wall: ``f = 0.5`` is the lighting designer's classic "half spacing
at the walls"; ``f > 0.5`` pulls the rows inwards (more light on a work plane with a border
zone), ``f < 0.5`` pushes them out (more light near the walls). Every layout is symmetric
about the room's centre lines. Positions that fall outside a non-rectangular room (or have
no ceiling above them) are dropped, so an L-shaped room gets a clipped regular grid.

Each position also gets a *class*: 1 for the end columns (first and last along the room's
length) when there are at least three columns, 0 otherwise; a mixed layout puts one
catalogue entry on class 0 and another on class 1 (stronger ends against the darker walls,
or weaker ones where walls reflect enough).
"""
from dataclasses import dataclass
import itertools

import numpy as np

from invrad_wb.core.inverse.locate import WORK_PLANE_CLEARANCE_M

#: edge fractions f tried along each axis (0.5 = half spacing at the walls); with many
#: luminaires along an axis the walls matter less and fewer are tried
EDGE_FRACTIONS = (0.5, 0.35, 0.65, 0.8, 1.0)
EDGE_FRACTIONS_MANY = (0.5, 0.75, 1.0)
MANY = 9
#: further edge fractions of shifted grids (rooms with surfaces that must stay dark)
SHIFT_FRACTIONS = (0.35, 0.5, 1.0, 1.5, 2.5)
#: luminaires keep this far from walls (metres, plus their radius)
WALL_CLEARANCE_M = 0.15
#: smallest spacing between luminaires of a grid (metres)
MIN_SPACING_M = 0.8
#: largest ratio of the spacings along the two axes of a grid
MAX_SPACING_RATIO = 3.0
#: a ceiling position under a slab opening (no ceiling there: a double-height void) hangs
#: as a pendant this far below the room's ceiling level, from the structure above
VOID_PENDANT_DROP_M = 0.15


@dataclass
class Geometry:
    """Positions of one candidate layout (catalogue entries are chosen later)."""

    ns: int
    nt: int
    fs: tuple               # edge fractions (first wall, last wall) along s
    ft: tuple               # ... along t
    plan: np.ndarray        # (L, 2) plan (s, t), metres
    positions: np.ndarray   # (L, 3) metres
    normals: np.ndarray     # (L, 3) unit facing directions
    cls: np.ndarray         # (L,) int, 0 inner, 1 end columns
    size: tuple = None      # (length, width) of the room's plan frame, metres
    #: the luminous half size (m) the positions were kept clear of the walls by: the
    #: layout serves entries whose half size is at most this (:class:`.search.RoomSearch`)
    clearance: float = None

    @property
    def count(self):
        return len(self.positions)

    def describe(self):
        """The layout as it stands in the room: the rows and columns kept (positions too
        close to a wall or outside the outline are dropped), their spacing and the
        distance of the outer ones from the walls, in metres."""
        s = np.unique(np.round(self.plan[:, 0], 6))
        t = np.unique(np.round(self.plan[:, 1], 6))
        even = all(len(v) < 3 or np.allclose(np.diff(v), v[1] - v[0], atol=1e-6)
                   for v in (s, t))
        if len(s) * len(t) != self.count or not even:   # an L, a stair, an opening...
            return (f"{self.count} positions of a {self.ns} x {self.nt} grid (the others"
                    " fall outside the room's outline or in an obstacle, or the design"
                    " left them out)")

        def axis(v, size):
            step = f"{v[1] - v[0]:.2f} m apart, " if len(v) > 1 else ""
            near, far = v[0], size - v[-1]
            wall = (f"{near:.2f} m" if abs(near - far) < 0.005
                    else f"{near:.2f} / {far:.2f} m")
            return step + wall + " from the walls"
        edge = ""
        if self.fs[0] != self.fs[1] or self.ft[0] != self.ft[1]:
            edge = " (shifted away from light-sensitive surfaces)"
        if self.size is None:
            return f"{len(s)} x {len(t)} grid{edge}"
        return (f"{len(s)} x {len(t)} grid: along the room {axis(s, self.size[0])}; across"
                f" {axis(t, self.size[1])}{edge}")

    @property
    def edge_deviation(self):
        """How far the wall distances are from the classic half spacing (0 = classic)."""
        return sum(abs(f - 0.5) for f in self.fs + self.ft)


def axis_positions(length, n, f):
    """``n`` positions along a side of ``length`` metres with edge fractions ``f = (f0, f1)``
    (the first and last luminaire ``f0 s`` and ``f1 s`` from the walls; a single luminaire
    divides the side in the ratio f0 : f1)."""
    f0, f1 = f
    if n == 1:
        return np.array([length * f0 / (f0 + f1)])
    s = length / (n - 1 + f0 + f1)
    return f0 * s + s * np.arange(n)


def _axis_options(n, fractions, shifted):
    """Edge-fraction pairs along one axis with ``n`` luminaires."""
    fr = fractions if n < MANY else (tuple(f for f in EDGE_FRACTIONS_MANY if f in fractions)
                                     or fractions)
    if n == 1 and not shifted:
        return [(0.5, 0.5)]
    pairs = [(f, f) for f in fr]
    if shifted:
        wide = tuple(sorted(set(fr) | set(SHIFT_FRACTIONS)))
        pairs += [(a, b) for a in wide for b in wide if a != b]
    return pairs


def mount(droom, plan, mounting, radius_m, wp_top_z):
    """World positions and normals of plan points for a mounting, and which are valid.

    ``ceiling``: on the ceiling above the point, facing along the ceiling's inward normal;
    ``pendant``: ``mounting.height_m`` above the floor facing down, below the ceiling.
    Points outside the room, within ``WALL_CLEARANCE_M + radius_m`` of a wall, or less than
    ``WORK_PLANE_CLEARANCE_M`` above the work plane are invalid. The room's no-mount zones
    (:meth:`~invrad_wb.core.design.room.DesignRoom.no_mount_at`) hold nothing where
    nothing may be mounted (a stair), nor within the wall clearance and the luminaire's
    radius of it (its body kept off the stair, as off a wall); under a slab opening, where there is no ceiling, a
    ceiling position becomes a pendant :data:`VOID_PENDANT_DROP_M` below the ceiling's
    level (hung from the structure above), facing down.
    """
    xy = droom.to_world(plan)
    zc, nc = droom.ceiling_at(xy)
    ok = np.isfinite(zc) & (droom.wall_distance(xy) >= WALL_CLEARANCE_M + radius_m)
    blocked, void = droom.no_mount_at(xy, WALL_CLEARANCE_M + radius_m)
    ok &= ~blocked
    if mounting.kind == "pendant":
        z = np.full(len(xy), droom.floor_z + mounting.height_m)
        ok &= z < np.where(np.isfinite(zc), zc, -np.inf) - 0.05
        nrm = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    else:
        z, nrm = np.where(np.isfinite(zc), zc, 0.0), nc
        if void.any():
            z = np.where(void, z - VOID_PENDANT_DROP_M, z)
            nrm = np.where(void[:, None], [0.0, 0.0, -1.0], nrm)
    ok &= z >= wp_top_z + WORK_PLANE_CLEARANCE_M
    return np.c_[xy, z], nrm, ok


def grid_counts(droom, n_min, n_max):
    """(ns, nt) pairs with ``n_min <= ns * nt <= n_max`` whose spacings are sensible."""
    ls, lt = droom.size
    out = []
    for ns in range(1, int(ls / MIN_SPACING_M) + 2):
        for nt in range(1, int(lt / MIN_SPACING_M) + 2):
            if not n_min <= ns * nt <= n_max:
                continue
            ss, st = ls / ns, lt / nt   # spacings at half-spacing edges
            if ns > 1 and nt > 1 and max(ss / st, st / ss) > MAX_SPACING_RATIO:
                continue
            out.append((ns, nt))
    return out


def grid_geometries(droom, mounting, radius_m, wp_top_z, n_min, n_max,
                    fractions=EDGE_FRACTIONS, shifted=False):
    """Every candidate grid of the room (list of :class:`Geometry`).

    Parameters
    ----------
    droom : DesignRoom
    mounting : spec.Mounting
    radius_m : float, the largest luminaire radius among the entries that may be used
    wp_top_z : float, height of the work plane (metres)
    n_min, n_max : int, range of luminaire counts to consider
    fractions : edge fractions tried along each axis (symmetric grids)
    shifted : bool, also grids shifted along one axis (different distances to the two
        walls): what a room with surfaces that must stay dark needs; without it every
        layout is symmetric about the room's centre lines
    """
    ls, lt = droom.size
    raw = []
    for ns, nt in grid_counts(droom, n_min, n_max):
        opt_s, opt_t = (_axis_options(n, fractions, shifted) for n in (ns, nt))
        sym_s = [p for p in opt_s if p[0] == p[1]]
        sym_t = [p for p in opt_t if p[0] == p[1]]
        combos = set(itertools.product(sym_s, sym_t))
        combos |= set(itertools.product(opt_s, sym_t)) | set(itertools.product(sym_s, opt_t))
        for fs, ft in sorted(combos):
            s, t = axis_positions(ls, ns, fs), axis_positions(lt, nt, ft)
            if ns > 1 and s[1] - s[0] < MIN_SPACING_M or nt > 1 and t[1] - t[0] < MIN_SPACING_M:
                continue
            plan = np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2)
            cls = np.repeat((np.arange(ns) == 0) | (np.arange(ns) == ns - 1), nt)
            cls = cls.astype(int) if ns >= 3 else np.zeros(len(plan), int)
            raw.append((ns, nt, fs, ft, plan, cls))
    if not raw:
        return []
    # one mounting query for all positions of all grids (the queries dominate otherwise)
    plan_all = np.concatenate([r[4] for r in raw])
    uniq, inv = np.unique(np.round(plan_all, 9), axis=0, return_inverse=True)
    pos_u, nrm_u, ok_u = mount(droom, uniq, mounting, radius_m, wp_top_z)
    out, start = [], 0
    for ns, nt, fs, ft, plan, cls in raw:
        k = inv.reshape(-1)[start:start + len(plan)]
        start += len(plan)
        ok = ok_u[k]
        if ok.any():
            out.append(Geometry(ns, nt, fs, ft, plan[ok], pos_u[k[ok]], nrm_u[k[ok]], cls[ok],
                                size=(ls, lt)))
    return out


# ----------------------------------------------------------------------- zone grids
#: a room cut into more rectangles than this gets no zone grids (columns, partitions:
#: the room's own clipped grids serve it)
MAX_ZONES = 3
#: the luminaires per m^2 of the zones of one layout stay within this factor of each other
#: (a designer keeps about the same spacing throughout)
ZONE_DENSITY_RATIO = 1.6
#: zone layouts kept per way of cutting a room, the most even densities first
MAX_ZONE_LAYOUTS = 400


class ZoneGeometry(Geometry):
    """A layout of one ``nx x ny`` grid with half spacing at the walls per rectangle of a
    room that is not one (an L: its two legs). ``zones``: ((nx, ny, (length, width)), ...)."""

    zones: tuple = ()

    def describe(self):
        parts = [f"{nx} x {ny} in the {a:.2f} x {b:.2f} m part" for nx, ny, (a, b) in self.zones]
        return f"one grid per rectangle of the room: {'; '.join(parts)}"


def room_rectangles(droom):
    """The ways of cutting a room's floor into rectangles along its axes: a list of
    decompositions, each a list of plan rectangles (s0, t0, s1, t1). Cut in bands across
    s and in bands across t (an L: its two legs, either way); only decompositions into 2
    to :data:`MAX_ZONES` rectangles are returned (a rectangle, or a room with columns in
    it, gets none)."""
    e = droom.to_plan(droom._edges.reshape(-1, 2)).reshape(-1, 2, 2)
    s = np.unique(np.round(e[..., 0], 6))
    t = np.unique(np.round(e[..., 1], 6))
    if len(s) < 2 or len(t) < 2 or len(s) * len(t) > 400:
        return []
    cs, ct = 0.5 * (s[1:] + s[:-1]), 0.5 * (t[1:] + t[:-1])
    inside = droom.inside(droom.to_world(np.stack(np.meshgrid(cs, ct, indexing="ij"),
                                                  -1).reshape(-1, 2)))
    inside = inside.reshape(len(cs), len(ct))
    out = []
    for axis in (0, 1):
        cells = inside if axis == 0 else inside.T
        a, b = (s, t) if axis == 0 else (t, s)
        rects, open_ = [], {}
        for i in range(cells.shape[0]):
            runs, j = [], 0
            while j < cells.shape[1]:
                if cells[i, j]:
                    k = j
                    while k + 1 < cells.shape[1] and cells[i, k + 1]:
                        k += 1
                    runs.append((j, k))
                    j = k + 1
                else:
                    j += 1
            nxt = {}
            for r in runs:
                nxt[r] = open_.pop(r, i)
            for (j, k), i0 in open_.items():
                rects.append((a[i0], b[j], a[i], b[k + 1]))
            open_ = nxt
        for (j, k), i0 in open_.items():
            rects.append((a[i0], b[j], a[cells.shape[0]], b[k + 1]))
        if axis == 1:
            rects = [(r[1], r[0], r[3], r[2]) for r in rects]
        rects = sorted(rects)
        area = sum((r[2] - r[0]) * (r[3] - r[1]) for r in rects)
        # the rectangles must be the floor (an outline with seams drawn through it is not)
        if (2 <= len(rects) <= MAX_ZONES and rects not in out
                and abs(area - droom.floor_area) <= 0.01 * droom.floor_area):
            out.append(rects)
    return out


def _zone_grids(droom, rect, mounting, radius_m, wp_top_z):
    """Every ``nx x ny`` grid with half spacing at the walls of one plan rectangle:
    [(nx, ny, plan (k, 2), positions, normals)] of the valid positions."""
    s0, t0, s1, t1 = rect
    ls, lt = s1 - s0, t1 - t0
    out = []
    for nx in range(1, int(ls / MIN_SPACING_M) + 2):
        for ny in range(1, int(lt / MIN_SPACING_M) + 2):
            ss, st = ls / nx, lt / ny
            if (nx > 1 and ss < MIN_SPACING_M or ny > 1 and st < MIN_SPACING_M
                    or nx > 1 and ny > 1 and max(ss / st, st / ss) > MAX_SPACING_RATIO):
                continue
            plan = np.stack(np.meshgrid(s0 + (np.arange(nx) + 0.5) * ss,
                                        t0 + (np.arange(ny) + 0.5) * st, indexing="ij"),
                            -1).reshape(-1, 2)
            pos, nrm, ok = mount(droom, plan, mounting, radius_m, wp_top_z)
            if ok.any():
                out.append((nx, ny, plan[ok], pos[ok], nrm[ok]))
    return out


def zone_geometries(droom, mounting, radius_m, wp_top_z, n_min, n_max):
    """Layouts of one regular grid per rectangle of a room that is not a rectangle
    (:func:`room_rectangles`; list of :class:`ZoneGeometry`): every ``nx x ny`` per zone
    with half spacing at its walls, combined where the zones' luminaire densities are
    within :data:`ZONE_DENSITY_RATIO` of each other and the count is in
    ``[n_min, n_max]``. What a lighting designer lays in an L: a grid over the whole
    outline, clipped, leaves one leg with a row on its wall or none down its middle."""
    out = []
    for si, rects in enumerate(room_rectangles(droom)):
        grids = [_zone_grids(droom, r, mounting, radius_m, wp_top_z) for r in rects]
        if not all(grids):
            continue
        area = [(r[2] - r[0]) * (r[3] - r[1]) for r in rects]
        found = []
        for combo in itertools.product(*[range(len(g)) for g in grids]):
            parts = [grids[z][j] for z, j in enumerate(combo)]
            n = sum(len(p[2]) for p in parts)
            if not n_min <= n <= n_max:
                continue
            dens = [len(p[2]) / a for p, a in zip(parts, area)]
            spread = max(dens) / min(dens)
            if spread <= ZONE_DENSITY_RATIO:
                found.append((spread, combo, parts))
        found.sort(key=lambda x: x[0])
        for spread, combo, parts in found[:MAX_ZONE_LAYOUTS]:
            g = ZoneGeometry((si,) + tuple(p[0] for p in parts), tuple(p[1] for p in parts),
                             (0.5, 0.5), (0.5, 0.5), np.concatenate([p[2] for p in parts]),
                             np.concatenate([p[3] for p in parts]),
                             np.concatenate([p[4] for p in parts]),
                             np.zeros(sum(len(p[2]) for p in parts), int),
                             size=tuple(droom.size))
            g.zones = tuple((p[0], p[1], (r[2] - r[0], r[3] - r[1]))
                            for p, r in zip(parts, rects))
            out.append(g)
    return out

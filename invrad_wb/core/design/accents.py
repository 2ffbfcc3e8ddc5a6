"""Accent lighting with aimed spots: a painted spot lit by adjustable spots on the ceiling.

A catalogue entry marked ``"aimable": true`` is an adjustable spot (a recessed gimbal, a
track spot) that may be tilted up to its ``max_tilt_deg`` from its mounting surface's
normal. When a room's catalogue has such entries, each painted spot (a
:class:`~invrad_wb.core.design.accent.Goal` of kind 'spot') that the general lighting leaves
too dark is lit by aimed spots of one entry:

* The spot's *footprint*: every vertex of its painted group (the core and the painted
  fall-off) and a ring of its own surface around it out to :data:`RING_FACTOR` times the
  painted radius, where the accent should add nothing. What the accent must add is the
  painted light above the general lighting's, ``max(target - general, 0)`` (0 in the ring).
* Candidates: every mounting position on a :data:`SEARCH_GRID_M` grid of the ceiling (or the
  pendant height) and every aimable entry, aimed at the spot's centre; a spot longer than a
  beam may take 2 or 3 luminaires side by side, aimed at the centres of equal parts of
  its long axis. A spot on an upright surface (a painting) is lit at a *sensible throw*:
  a tilt within :data:`WALL_TILT_DEG` off vertical (the museum "30 degree" rule: steep
  enough for no veiling reflection in the glazing at the viewer's eye, shallow enough for
  short frame shadows) where such a position exists; a horizontal one (a table) at any tilt
  the entry allows.
* Each candidate's flux is the one that makes the fast estimate (direct light through the
  tilted intensity distribution, inverse square, no shadows) meet the spot's core mean (the
  requirement, :data:`~invrad_wb.constants.SPOT_TOLERANCE`), within the entry's dimming
  range; candidates are ranked by their *shape error* (area-weighted relative RMS between
  the light added and the light needed over the footprint: a beam too narrow leaves the
  painted fall-off dark, one too wide spills on the ring). The fewest luminaires within
  :data:`MORE_SLACK` of the best shape win, then the least watts within
  :data:`SHAPE_SLACK`; the winner's position and aim point are refined locally, then it is
  checked exactly (shadows, interreflection) and its flux corrected once.

How well each spot is met is measured on the exact light of the whole installation over its
footprint: its core mean (the verdict), its peak, its *size* (the area at least half the
painted peak, against the painted one) and its *fall-off* (the rim's mean light, where the
painting is below half its peak, as a share of the core's, against the painted share).
"""
from dataclasses import dataclass, field

import numpy as np

from invrad_wb.constants import SPOT_TOLERANCE
from invrad_wb.core.design.accent import (ACCENT_MIN_GAP_M, SPOT_CORE, SpotResult,
                                          accent_wanted, within)
from invrad_wb.core.design.evaluate import luminaires_of
from invrad_wb.core.design.layouts import mount
from invrad_wb.core.model.aiming import aimed_c0, tilt_pan

#: the footprint's ring reaches this factor times the painted radius from the spot's centre
RING_FACTOR = 1.6
#: mounting positions tried for aimed spots, spacing (m); the winner is refined to
#: :data:`REFINE_STEP_M`
SEARCH_GRID_M = 0.15
REFINE_STEP_M = 0.05
#: tilt off vertical at which a spot on an upright surface is lit where possible (degrees)
WALL_TILT_DEG = (20.0, 40.0)
#: a spot may take up to this many aimed luminaires side by side
MAX_PER_SPOT = 3
#: more luminaires are used only when their shape error is below this share of one fewer's
MORE_SLACK = 0.8
#: among candidates within this factor of the best shape error, the least watts win
SHAPE_SLACK = 1.1
#: footprint points per spot at most (a deterministic subsample beyond)
MAX_FOOTPRINT_POINTS = 600
#: the peak and the half-peak area are met within these shares of the painted ones
PEAK_TOLERANCE = 0.2
SIZE_TOLERANCE = 0.35


# ------------------------------------------------------------------ the spot's footprint
@dataclass
class Footprint:
    """Where a painted spot lies and what it asks, on its own surface.

    Attributes
    ----------
    points, normals : (m, 3) float64, the painted vertices then the ring's (metres)
    target : (m,) float64, painted lux (0 in the ring)
    weight : (m,) float64, each vertex's share of the surface (m^2)
    painted : (m,) bool
    centre : (3,) float64, target-weighted centre (metres)
    axis : (3,) float64, the painted group's long axis in its surface (unit)
    extent : (2,) float64, the core's extent along ``axis`` from ``centre`` (min, max) m
    """

    points: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    target: np.ndarray = field(repr=False)
    weight: np.ndarray = field(repr=False)
    painted: np.ndarray = field(repr=False)
    centre: np.ndarray = None
    axis: np.ndarray = None
    extent: tuple = (0.0, 0.0)

    @property
    def peak(self):
        return float(self.target.max())

    @property
    def upright(self):
        """The spot lies on an upright surface (a wall, a painting)."""
        n = np.average(self.normals[self.painted], axis=0, weights=self.weight[self.painted])
        return abs(n[2]) <= 0.3 * np.linalg.norm(n)


def footprint(scene, room, goal):
    """The :class:`Footprint` of a spot goal: its painted group (the connected vertices of
    positive target around its core) and a ring of its planes around it."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    t = scene.vertex_targets()
    sel = np.flatnonzero((scene.face_room == room) & ~scene.face_virtual)
    faces = scene.faces[sel]
    n = len(scene.vertices)
    lit = np.isfinite(t) & (t > 0)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = edges[lit[edges[:, 0]] & lit[edges[:, 1]]]
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    verts = np.unique(faces.reshape(-1))
    vl = verts[lit[verts]]
    # the component that holds the goal's brightest point
    top = goal.points[int(np.argmax(goal.target))]
    seed = vl[int(np.argmin(np.linalg.norm(scene.vertices[vl] - top, axis=1)))]
    group = vl[label[vl] == label[seed]]
    vert_area = np.bincount(faces.reshape(-1), weights=np.repeat(scene.face_areas[sel] / 3, 3),
                            minlength=n)
    w = vert_area[group]
    centre = (t[group] * w) @ scene.vertices[group] / float(np.sum(t[group] * w))
    radius = float(np.linalg.norm(scene.vertices[group] - centre, axis=1).max())
    # the ring: vertices of the planes the group lies on, near it, painted by no one
    touched = np.isin(faces, group).any(axis=1)
    planes = np.unique(scene.face_plane[sel][touched])
    on = np.unique(faces[np.isin(scene.face_plane[sel], planes)].reshape(-1))
    near = np.linalg.norm(scene.vertices[on] - centre, axis=1) <= RING_FACTOR * max(radius,
                                                                                    0.05)
    ring = on[near & ~lit[on]]
    idx = np.concatenate([group, ring])
    if len(idx) > MAX_FOOTPRINT_POINTS:
        keep = np.linspace(0, len(idx) - 1, MAX_FOOTPRINT_POINTS).astype(int)
        scale = len(idx) / MAX_FOOTPRINT_POINTS
        idx = idx[keep]
    else:
        scale = 1.0
    painted = np.isin(idx, group)
    target = np.where(painted, t[idx], 0.0)
    pts, nrm = scene.vertices[idx], scene.vertex_normals[idx]
    # the long axis of the core in the surface: its principal direction
    core = painted & (target >= SPOT_CORE * target.max())
    d = pts[core] - centre
    nbar = nrm[painted].mean(axis=0)
    nbar /= np.linalg.norm(nbar)
    d = d - np.outer(d @ nbar, nbar)
    cov = (d * vert_area[idx][core][:, None]).T @ d
    vals, vecs = np.linalg.eigh(cov)
    axis = vecs[:, int(np.argmax(vals))]
    s = d @ axis
    return Footprint(pts, nrm, target, vert_area[idx] * scale, painted, centre, axis,
                     (float(s.min()), float(s.max())))


# ------------------------------------------------------------------ fast light of aimed spots
def aimed_response(points, normals, positions, aims, c0s, photometry=None):
    """Direct illuminance per lumen (m, L) lux/lm of aimed point sources, no shadows.

    Parameters
    ----------
    points, normals : (m, 3) float64, receivers (metres, unit normals)
    positions, aims, c0s : (L, 3) float64, luminaire centres, photometric axes (unit) and
        C = 0 axes (perpendicular to the aims)
    photometry : object with ``intensity_per_lm(local_dirs)`` or None (lambertian)
    """
    return _Rays(points, normals, positions, aims, c0s).response(photometry)


class _Rays:
    """The geometry of receivers seen from aimed point sources, shared by every
    intensity distribution: directions in each luminaire's frame and ``cos / d^2``."""

    def __init__(self, points, normals, positions, aims, c0s):
        d = points[:, None, :] - positions[None]
        r2 = np.maximum(np.einsum("mli,mli->ml", d, d), 1e-12)
        d = d / np.sqrt(r2)[..., None]
        self.geom = np.maximum(-np.einsum("mi,mli->ml", normals, d), 0.0) / r2
        v = np.cross(aims, c0s)
        self.local = np.stack([np.einsum("mli,li->ml", d, c0s),
                               np.einsum("mli,li->ml", d, v),
                               np.einsum("mli,li->ml", d, aims)], -1)

    def response(self, photometry):
        if photometry is None:
            return np.maximum(self.local[..., 2], 0.0) / np.pi * self.geom
        return photometry.intensity_per_lm(self.local) * self.geom


def _frames(positions, mount_normals, targets):
    """Aims (unit, towards ``targets``) and their C = 0 axes (:func:`aimed_c0`, here for
    many at once); (..., 3) each."""
    from invrad_wb.core.model.scene import plane_basis
    aims = targets - positions
    aims = aims / np.linalg.norm(aims, axis=-1, keepdims=True)
    m = np.broadcast_to(mount_normals, aims.shape)
    keys, inv = np.unique(np.round(m.reshape(-1, 3), 9), axis=0, return_inverse=True)
    u = np.array([plane_basis(k)[0] for k in keys])[inv.reshape(-1)].reshape(aims.shape)
    # Rodrigues' smallest rotation m -> aim applied to u: u + v x u + v x (v x u) / (1 + c)
    v = np.cross(m, aims)
    c = np.einsum("...i,...i->...", m, aims)[..., None]
    vu = np.cross(v, u)
    c0 = u + vu + np.cross(v, vu) / np.maximum(1.0 + c, 1e-12)
    return aims, c0


def _tilt(mount_normals, aims):
    return np.degrees(np.arccos(np.clip(np.einsum("...i,...i->...", mount_normals, aims),
                                        -1.0, 1.0)))


@dataclass
class _Group:
    entry: int
    positions: np.ndarray        # (k, 3)
    mounts: np.ndarray           # (k, 3) mount normals
    targets: np.ndarray          # (k, 3) aim points
    flux: float                  # lm each
    error: float
    watts: float


def _aim_points(fp, k):
    """(k, 3) aim points: the centres of k equal parts of the core's long axis."""
    if k == 1:
        return fp.centre[None]
    lo, hi = fp.extent
    s = lo + (np.arange(k) + 0.5) * (hi - lo) / k
    return fp.centre + s[:, None] * fp.axis


def _place(base_pos, base_mount, aim_pts, fp):
    """(L, k, 3) positions of k luminaires for each base position: shifted with their aim
    points across the mounting plane (a track along a long painting), or side by side
    across the throw where that shift is too small to keep them apart."""
    k = len(aim_pts)
    off = aim_pts - aim_pts.mean(axis=0)
    m = base_mount[:, None]
    off = off[None] - np.einsum("lki,lki->lk", np.broadcast_to(off[None], m.shape[:1] + off.shape),
                                np.broadcast_to(m, (len(base_pos),) + off.shape))[..., None] * m
    if k > 1 and np.linalg.norm(off[0, 1] - off[0, 0]) < ACCENT_MIN_GAP_M:
        throw = fp.centre - base_pos
        side = np.cross(base_mount, throw)
        side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
        steps = (np.arange(k) - (k - 1) / 2) * ACCENT_MIN_GAP_M
        return base_pos[:, None] + steps[None, :, None] * side[:, None]
    return base_pos[:, None] + off


class AimedAccents:
    """The search for one room: its mounting positions and aimable entries."""

    def __init__(self, droom, rs, entries, photometry, mf, wp_top_z):
        self.droom, self.rs, self.entries = droom, rs, entries
        self.photometry, self.mf, self.wp_top_z = photometry, mf, wp_top_z
        self.radius = max(e.radius_m for e in entries)
        self.positions, self.mounts = self._grid(SEARCH_GRID_M)

    def _grid(self, step, around=None, reach=None):
        droom, rs = self.droom, self.rs
        if rs.mounting.kind == "wall":
            return np.zeros((0, 3)), np.zeros((0, 3))
        if around is None:
            s = np.arange(step / 2, droom.size[0], step)
            t = np.arange(step / 2, droom.size[1], step)
            plan = np.stack(np.meshgrid(s, t, indexing="ij"), -1).reshape(-1, 2)
        else:
            c = droom.to_plan(around[None, :2])[0]
            g = np.arange(-reach, reach + step / 2, step)
            plan = c + np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
        pos, nrm, ok = mount(droom, plan, rs.mounting, self.radius, self.wp_top_z)
        return pos[ok], nrm[ok]

    def _mounted(self, pos):
        """``pos`` (L, k, 3) put on the mounting: positions and mount normals (L, k, 3), and
        (L,) whether every one of a group is allowed there."""
        L, k = pos.shape[:2]
        plan = self.droom.to_plan(pos.reshape(-1, 3)[:, :2])
        p, n, ok = mount(self.droom, plan, self.rs.mounting, self.radius, self.wp_top_z)
        return p.reshape(L, k, 3), n.reshape(L, k, 3), ok.reshape(L, k).all(axis=1)

    def _evaluate(self, fp, need, goal, bc, tc, pos, mn, aim_pts, others, shade,
                  entries=None):
        """Candidate groups ``pos`` (L, k, 3) with mount normals ``mn`` aimed at
        ``aim_pts`` (k, 3), for each entry index in ``entries`` (default: all): a list of
        (entry, flux each (lm), shape error, allowed and meeting the spot's mean by the
        fast estimate) with arrays (L,)."""
        L, k = pos.shape[:2]
        tg = np.broadcast_to(aim_pts[None], pos.shape)
        aims, c0 = _frames(pos.reshape(-1, 3), mn.reshape(-1, 3), tg.reshape(-1, 3))
        tilt = _tilt(mn.reshape(-1, 3), aims).reshape(L, k)
        rays = _Rays(np.concatenate([fp.points, goal.points]),
                     np.concatenate([fp.normals, goal.normals]), pos.reshape(-1, 3), aims, c0)
        apart = np.ones(L, bool)
        if k > 1:                                     # a group's own luminaires apart too
            d = np.linalg.norm(pos[:, :, None] - pos[:, None], axis=3) + 1e9 * np.eye(k)
            apart &= d.min(axis=(1, 2)) >= ACCENT_MIN_GAP_M - 1e-9
        if len(others):
            gap = np.linalg.norm(pos[:, :, None] - others[None, None], axis=3).min(axis=2)
            apart &= gap.min(axis=1) >= ACCENT_MIN_GAP_M
        band = np.ones(L, bool)
        if fp.upright:                                # a sensible throw where there is one
            band = np.all((tilt >= WALL_TILT_DEG[0]) & (tilt <= WALL_TILT_DEG[1]), axis=1)
        shade_rays = None
        w, m = fp.weight, len(fp.points)
        out = []
        for ke in (range(len(self.entries)) if entries is None else entries):
            e = self.entries[ke]
            phot = self.photometry.get(e.name)
            U = self.mf * rays.response(phot).reshape(-1, L, k).sum(axis=2)  # (m, L) lx/lm
            gain = U[m:].mean(axis=0)                                # core lux per lm
            flux = np.clip((tc - bc) / np.maximum(gain, 1e-30), e.dimming[0] * e.flux_lm,
                           e.flux_lm)
            ok = apart & (np.abs(bc + gain * flux - tc) <= 0.95 * SPOT_TOLERANCE * tc)
            ok &= np.all(tilt <= e.max_tilt_deg + 1e-9, axis=1)
            err = np.sqrt((w @ (U[:m] * flux - need[:, None]) ** 2)
                          / max(float(w @ need ** 2), 1e-30))
            if shade is not None and ok.any():
                sp, sn, sbase, limit = shade
                if shade_rays is None:
                    shade_rays = _Rays(sp, sn, pos.reshape(-1, 3), aims, c0)
                S = self.mf * shade_rays.response(phot).reshape(len(sp), L, k).sum(axis=2)
                ok &= np.max(sbase[:, None] + S * flux, axis=0) <= limit
            if (ok & band).any():
                ok &= band
            out.append((ke, flux, err, ok))
        return out

    def best(self, fp, base_fp, goal, base_goal, others, shade=None):
        """The :class:`_Group` of aimed luminaires that meets the spot with the best shape
        (fewest luminaires, least watts; see the module docstring), or None."""
        if not len(self.positions):
            return None
        need = np.maximum(fp.target - base_fp, 0.0)
        need[~fp.painted] = 0.0
        tc, bc = goal.target_mean, float(np.mean(base_goal))
        found = []                                       # (k, error, watts, group)
        for k in range(1, MAX_PER_SPOT + 1):
            aim_pts = _aim_points(fp, k)
            pos, mn, valid = self._mounted(_place(self.positions, self.mounts, aim_pts, fp))
            if not valid.any():
                continue
            pos, mn = pos[valid], mn[valid]
            for ke, flux, err, ok in self._evaluate(fp, need, goal, bc, tc, pos, mn,
                                                    aim_pts, others, shade):
                e = self.entries[ke]
                for i in np.flatnonzero(ok):
                    watts = k * e.watts * flux[i] / e.flux_lm
                    found.append((k, err[i], watts, _Group(ke, pos[i], mn[i], aim_pts,
                                                           float(flux[i]), float(err[i]),
                                                           watts)))
        if not found:
            return None
        best_k = {}
        for k, err, _, _ in found:
            best_k[k] = min(best_k.get(k, np.inf), err)
        k_use = min(best_k)
        for k in sorted(best_k)[1:]:
            if best_k[k] < MORE_SLACK * best_k[k_use]:
                k_use = k
        pool = [f for f in found if f[0] == k_use and f[1] <= SHAPE_SLACK * best_k[k_use]]
        group = min(pool, key=lambda f: (f[2], f[1]))[3]
        return self._refine(group, fp, need, goal, bc, tc, others, shade)

    def _refine(self, group, fp, need, goal, bc, tc, others, shade):
        """The group moved on a finer grid around its position and its aim points shifted
        in the spot's surface (an oblique beam is brightest off its axis' hit point): the
        best shape among those that still meet the spot."""
        k = len(group.positions)
        centre = group.positions.mean(axis=0)
        pos1, _ = self._grid(REFINE_STEP_M, around=centre, reach=SEARCH_GRID_M)
        if not len(pos1):
            return group
        pos, mn, valid = self._mounted(pos1[:, None] + (group.positions - centre)[None])
        pos, mn = pos[valid], mn[valid]
        if not len(pos):
            return group
        nbar = fp.normals[fp.painted].mean(axis=0)
        nbar /= np.linalg.norm(nbar)
        a = fp.axis
        b = np.cross(nbar, a)
        span = max(0.5 * (fp.extent[1] - fp.extent[0]) / k, 0.05)
        e = self.entries[group.entry]
        best = group
        for da in np.linspace(-0.5, 0.5, 5) * span:
            for db in np.linspace(-0.5, 0.5, 5) * span:
                aim_pts = group.targets + da * a + db * b
                [(_, flux, err, ok)] = self._evaluate(fp, need, goal, bc, tc, pos, mn,
                                                      aim_pts, others, shade, [group.entry])
                ok &= err < best.error
                if ok.any():
                    i = int(np.flatnonzero(ok)[np.argmin(err[ok])])
                    best = _Group(group.entry, pos[i], mn[i], aim_pts, float(flux[i]),
                                  float(err[i]), k * e.watts * flux[i] / e.flux_lm)
        return best

    def luminaires(self, group, room, flux=None):
        e = self.entries[group.entry]
        aims, c0 = _frames(group.positions, group.mounts, group.targets)
        out = []
        for p, m, a, c, t in zip(group.positions, group.mounts, aims, c0, group.targets):
            lum = luminaires_of([p], [a], [group.flux if flux is None else flux], self.entries,
                                [group.entry], room, self.photometry)[0]
            lum.c0 = c
            tilt, pan = tilt_pan(a, m)
            lum.extra.update({"role": "accent", "aimed": True,
                              "mount_normal": [round(float(x), 6) for x in m],
                              "tilt_deg": round(tilt, 2), "pan_deg": round(pan, 2),
                              "aimed_at": [round(float(x), 4) for x in t]})
            out.append(lum)
        return out


# ------------------------------------------------------------------ results
class AimedSpotResult(SpotResult):
    """A spot lit by aimed luminaires, with how well its shape is met.

    ``general_fp`` / ``accent_fp``: exact maintained lux (m,) over the footprint of the
    general lighting and of all the accents; dimming the general lighting afterwards
    (setting ``base_mean``) scales its share.
    """

    def __init__(self, goal, achieved_mean, base_mean, accents, watts, note, fp, general_fp,
                 accent_fp):
        super().__init__(goal, achieved_mean, base_mean, accents[0] if accents else None,
                         watts, note)
        self.accents = list(accents)
        self.fp, self._general_fp, self._accent_fp = fp, general_fp, accent_fp
        self._base0 = base_mean

    # base_mean is set by the design's re-dimming: the footprint's general light follows
    @property
    def base_mean(self):
        return self._base

    @base_mean.setter
    def base_mean(self, value):
        self._base = value

    @property
    def shape(self):
        """{'peak_lux', 'target_peak_lux', 'size_m2', 'target_size_m2', 'rim_share',
        'target_rim_share', 'shape_error'} of the exact light over the footprint
        (:func:`spot_shape`)."""
        scale = self._base / self._base0 if self._base0 > 0 else 1.0
        return spot_shape(self.fp, scale * self._general_fp, self._accent_fp)

    @property
    def ok(self):
        if not within(self.achieved_mean, self.goal.target_mean):
            return False
        if not self.accents:
            return True
        s = self.shape
        return (abs(s["peak_lux"] / s["target_peak_lux"] - 1) <= PEAK_TOLERANCE
                and abs(s["size_m2"] / max(s["target_size_m2"], 1e-12) - 1) <= SIZE_TOLERANCE)

    def to_dict(self):
        d = super().to_dict()
        if self.accents:
            d["accent_count"] = len(self.accents)
            d["accent_tilt_deg"] = [lum.extra.get("tilt_deg") for lum in self.accents]
            d.update({k: round(float(v), 3) for k, v in self.shape.items()})
            d["peak_tolerance"], d["size_tolerance"] = PEAK_TOLERANCE, SIZE_TOLERANCE
        return d

    def accent_words(self):
        """The report's accent cell: '2 x SPOT-35 aimed 32, 32 deg; peak 554/544 lx,
        half-peak area 1.46/1.67 m2' (None without accents)."""
        if not self.accents:
            return None
        s = self.shape
        return (f"{len(self.accents)} x {self.accents[0].extra.get('type')} aimed"
                f" {', '.join(str(round(lum.extra['tilt_deg'])) for lum in self.accents)} deg;"
                f" peak {s['peak_lux']:.0f}/{s['target_peak_lux']:.0f} lx, half-peak area"
                f" {s['size_m2']:.2f}/{s['target_size_m2']:.2f} m2")

    def describe(self):
        """The design note: the verdict, the accents and the shape, in one line."""
        g = self.goal
        head = (f"{g.label()}: {self.achieved_mean:.0f} lx for {g.target_mean:.0f} lx"
                f" (+/- {SPOT_TOLERANCE:.0%}): {'met' if self.ok else 'NOT met'}")
        if not self.accents:
            return head + (f"; {self.note}" if self.note else "")
        s = self.shape
        tilts = ", ".join(f"{lum.extra['tilt_deg']:.0f}" for lum in self.accents)
        n = len(self.accents)
        return (head + f" with {n} aimed {self.accents[0].extra.get('type')}"
                f" (tilt {tilts} deg); peak {s['peak_lux']:.0f} lx for"
                f" {s['target_peak_lux']:.0f} lx; the accent's light: half-peak area"
                f" {s['size_m2']:.2f} m2 for {s['target_size_m2']:.2f} m2 asked above the"
                f" general lighting, fall-off: its rim gets {100 * s['rim_share']:.0f} % of"
                f" the core's light for {100 * s['target_rim_share']:.0f} %; shape error"
                f" {100 * s['shape_error']:.0f} % RMS")


def spot_shape(fp, general, added):
    """Peak, size and fall-off of a spot's light against the painted ones.

    ``general`` / ``added``: lux (m,) over the footprint of the general lighting and of the
    accents. The peak is the total's; the size and the fall-off are those of the light the
    accents add against the light the painting asks above the general lighting
    (``max(target - general, 0)``): the half-peak area (m^2), and the rim's mean as a share
    of the core's (the rim: painted points needing less than half the peak need)."""
    w = fp.weight
    need = np.where(fp.painted, np.maximum(fp.target - general, 0.0), 0.0)
    top = float(need.max())
    core = need >= 0.5 * top
    rim = fp.painted & ~core

    def share(x):
        c = np.average(x[core], weights=w[core])
        return float(np.average(x[rim], weights=w[rim]) / c) if rim.any() and c > 0 else 0.0

    err = np.sqrt(float(w @ (added - need) ** 2) / max(float(w @ need ** 2), 1e-30))
    return {"peak_lux": float((general + added).max()), "target_peak_lux": fp.peak,
            "size_m2": float(w[added >= 0.5 * top].sum()),
            "target_size_m2": float(w[core].sum()),
            "rim_share": share(added), "target_rim_share": share(need),
            "shape_error": err}


# ------------------------------------------------------------------ the room's accents
def light_spots_aimed(scene, model, droom, rs, entries, photometry, general, goals, wp_top_z,
                      shade=None, shade_limit=5.0):
    """Light each spot the general lighting leaves too dark with aimed ``entries``.

    Parameters as :func:`invrad_wb.core.design.accent.light_spots` (``entries``: the aimable
    ones), with the ``scene`` (the painted targets around each spot).

    Returns
    -------
    accents : list of Luminaire (``extra['role'] == 'accent'``, with tilt and pan)
    results : list of SpotResult, one per goal (:class:`AimedSpotResult` for spots)
    """
    room = droom.room
    search = AimedAccents(droom, rs, entries, photometry, model.mf, wp_top_z)
    fps = [footprint(scene, room, g) if g.kind == "spot" else None for g in goals]
    n_shade = len(shade[0]) if shade is not None else 0
    # every receiver in one array: the goals' points, the footprints, the shade points
    blocks = [(g.points, g.normals) for g in goals]
    blocks += [(f.points, f.normals) for f in fps if f is not None]
    if n_shade:
        blocks.append(shade)
    pts = np.concatenate([b[0] for b in blocks])
    nrm = np.concatenate([b[1] for b in blocks])
    ends = np.cumsum([0] + [len(b[0]) for b in blocks])
    fp_slot, j = {}, len(goals)
    for i, f in enumerate(fps):
        if f is not None:
            fp_slot[i], j = j, j + 1
    part = lambda arr, b: arr[ends[b]:ends[b + 1]]                      # noqa: E731
    lux = model.exact_at(pts, nrm, general)
    general_lux = lux.copy()
    accents, notes, groups = [], {}, {}
    for i, goal in enumerate(goals):
        base = part(lux, i)
        wanted, note = accent_wanted(goal, base)
        if not wanted:
            if note:
                notes[i] = note
            continue
        others = np.array([lum.position for lum in general + accents]).reshape(-1, 3)
        sh = None
        if n_shade:
            sh = (shade[0], shade[1], part(lux, len(blocks) - 1), shade_limit)
        fp = fps[i]
        group = search.best(fp, part(lux, fp_slot[i]), goal, base, others, sh)
        if group is None:
            notes[i] = (f"no aimable catalogue luminaire at an allowed position and tilt"
                        f" brings it from {np.mean(base):.0f} to {goal.target_mean:.0f} lx"
                        f" (+/- {SPOT_TOLERANCE:.0%})")
            continue
        e = entries[group.entry]
        lums = search.luminaires(group, room)
        own = model.exact_at(pts, nrm, lums)
        gain = float(np.mean(part(own, i))) / group.flux                 # exact lx per lm
        if not within(float(np.mean(base)) + gain * group.flux, goal.target_mean):
            # one exact correction (the fast estimate has no shadows, no interreflection)
            want = (goal.target_mean - float(np.mean(base))) / max(gain, 1e-30)
            new = float(np.clip(want, e.dimming[0] * e.flux_lm, e.flux_lm))
            own, lums = own * (new / group.flux), search.luminaires(group, room, new)
            group.flux = new
        accents += lums
        groups[i] = (lums, len(lums) * e.watts * group.flux / e.flux_lm)
        lux = lux + own
    results = []
    for i, goal in enumerate(goals):
        b, a = part(general_lux, i), part(lux, i)
        if goal.kind != "spot":
            results.append(SpotResult(goal, float(np.mean(a)), float(np.mean(b))))
            continue
        lums, watts = groups.get(i, ([], 0.0))
        s = fp_slot[i]
        gen_fp = part(general_lux, s)
        results.append(AimedSpotResult(goal, float(np.mean(a)), float(np.mean(b)), lums,
                                       watts, notes.get(i, ""), fps[i], gen_fp,
                                       part(lux, s) - gen_fp))
    return accents, results

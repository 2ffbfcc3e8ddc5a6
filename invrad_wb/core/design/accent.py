"""Accent lighting: painted spots as design requirements (mean within 10 % of the target).

A room's targets on its real surfaces fall into connected groups of vertices with a positive
target. A group that covers a small part of the planes it lies on and whose target varies
(a painted spot with its fall-off) is a *spot*: a requirement met when the maintained mean
illuminance over its core (the points painted at least :data:`SPOT_CORE` of its peak) is
within :data:`SPOT_TOLERANCE` of the target's mean there. Larger or
constant groups (a wall painted uniformly, physically exact targets everywhere) are
*surface goals*: reported, not judged (no catalogue design can match them point by point).

After the work-plane layout is chosen, each spot the general lighting leaves too dark gets
one accent luminaire: every allowed mounting position on a :data:`ACCENT_GRID_M` grid and
every catalogue entry is tried with its least-squares flux (within its dimming range) on
the spot's shortfall; among those whose fast estimate (direct light, the intensity
distribution, no shadows) meets the spot and keeps shade points dark, the one of least
watts (then of the closest shape) is taken and checked exactly (shadows, radiosity), its
flux corrected once by the exact ratio when its dimming range allows.
"""
from dataclasses import dataclass, field

import numpy as np

from invrad_wb.core.design.evaluate import luminaires_of, unit_response
from invrad_wb.core.design.layouts import mount
from invrad_wb.constants import SPOT_TOLERANCE

#: A group of target points covering more than this fraction of the planes it lies on is a
#: surface goal, not a spot.
SPOT_MAX_AREA_FRACTION = 0.25
#: A group whose target varies by less than this fraction of its maximum is uniform.
SPOT_MIN_VARIATION = 0.2
#: A spot is judged on its core: the points whose target is at least this fraction of its
#: peak (the painted fall-off around it is a shape, not a requirement).
SPOT_CORE = 0.5
#: Spacing of the candidate accent positions (metres).
ACCENT_GRID_M = 0.1
#: An accent keeps at least this distance from every other luminaire (metres): two
#: fixtures side by side read as a mistake on the ceiling.
ACCENT_MIN_GAP_M = 0.4
#: Points per goal at most (a deterministic subsample beyond).
MAX_GOAL_POINTS = 400
#: Among accents within this factor of the least watts, the closest shape wins.
WATTS_SLACK = 1.2


@dataclass
class Goal:
    """A connected group of target points on a room's real surfaces."""
    kind: str                      # "spot" or "surface"
    points: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    target: np.ndarray = field(repr=False)
    area_m2: float = 0.0
    n_vertices: int = 0
    #: the surface it lies on (most of its area) in words: 'ceiling', 'wall x = 4.00 m
    #: (facing -x)', ... ('' when unknown)
    surface: str = ""

    @property
    def centre(self):
        w = self.target / max(float(self.target.sum()), 1e-12)
        return w @ self.points

    @property
    def target_mean(self):
        return float(np.mean(self.target))

    def label(self):
        c = self.centre
        on = f" on the {self.surface}" if self.surface else ""
        what = "spot" if self.kind == "spot" else "surface goal"
        return f"{what}{on} at ({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}) m"


def find_goals(scene, room):
    """The room's target groups (:class:`Goal`), largest target first."""
    if not scene.has_targets:
        return []
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    t = scene.vertex_targets()
    sel = np.flatnonzero((scene.face_room == room) & ~scene.face_virtual)
    if not len(sel):
        return []
    faces = scene.faces[sel]
    lit = np.isfinite(t) & (t > 0)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = edges[lit[edges[:, 0]] & lit[edges[:, 1]]]
    verts = np.unique(faces.reshape(-1))
    verts = verts[lit[verts]]
    if not len(verts):
        return []
    n = len(scene.vertices)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    # each face's area shared among its corners (vertex areas)
    vert_area = np.bincount(faces.reshape(-1), weights=np.repeat(scene.face_areas[sel] / 3, 3),
                            minlength=n)
    plane_area = np.bincount(scene.face_plane[sel], weights=scene.face_areas[sel],
                             minlength=len(scene.planes))
    floor_z = float(scene.vertices[faces.reshape(-1), 2].min())
    goals = []
    for comp in np.unique(label[verts]):
        idx = verts[label[verts] == comp]
        tv = t[idx]
        area = float(vert_area[idx].sum())
        # the planes it lies on: a spot covers a small part of them, a goal fills them
        touched = np.isin(faces, idx).any(axis=1)
        under = float(plane_area[np.unique(scene.face_plane[sel][touched])].sum())
        varies = np.ptp(tv) > SPOT_MIN_VARIATION * tv.max()
        kind = ("spot" if varies and len(idx) >= 3
                and area <= SPOT_MAX_AREA_FRACTION * under else "surface")
        if kind == "spot":        # judged on its core: a painted fall-off ends at 0 lx
            idx = idx[tv >= SPOT_CORE * tv.max()]
        if len(idx) > MAX_GOAL_POINTS:
            idx = idx[np.linspace(0, len(idx) - 1, MAX_GOAL_POINTS).astype(int)]
        goals.append(Goal(kind, scene.vertices[idx], scene.vertex_normals[idx], t[idx],
                          area, int(np.count_nonzero(label[verts] == comp)),
                          _surface_words(scene, sel[touched], floor_z)))
    goals.sort(key=lambda g: -g.target_mean)
    return goals


def _surface_words(scene, faces, floor_z):
    """The plane that holds most of ``faces``' area, in words (the report's wording)."""
    from invrad_wb.core.output.images import describe_plane
    if not len(faces):
        return ""
    area = np.bincount(scene.face_plane[faces], weights=scene.face_areas[faces])
    return describe_plane(scene.planes[int(np.argmax(area))], floor_z)


def within(achieved_mean, target_mean, tol=SPOT_TOLERANCE):
    return abs(achieved_mean - target_mean) <= tol * target_mean + 1e-9


def accent_wanted(goal, base):
    """Whether ``goal`` wants an accent over the general lighting's lux ``base`` at its
    points: ``(True, None)`` when a spot is short of its level; ``(False, None)`` when it is
    no spot or already within tolerance; ``(False, note)`` when the general lighting alone
    is brighter than asked (an accent cannot take light away)."""
    mean = float(np.mean(base))
    if goal.kind != "spot" or within(mean, goal.target_mean):
        return False, None
    if mean > goal.target_mean:
        return False, (f"the general lighting alone gives {mean:.0f} lx for"
                       f" {goal.target_mean:.0f} lx")
    return True, None


@dataclass
class SpotResult:
    goal: Goal
    achieved_mean: float
    base_mean: float               # from the general lighting alone
    accent: object = None          # the accent Luminaire, if one was added
    accent_watts: float = 0.0
    note: str = ""

    @property
    def ok(self):
        return within(self.achieved_mean, self.goal.target_mean)

    def to_dict(self):
        g = self.goal
        d = {"kind": g.kind, "surface": g.surface,
             "centre_m": [round(float(x), 3) for x in g.centre],
             "target_mean_lux": round(g.target_mean, 2),
             "achieved_mean_lux": round(self.achieved_mean, 2),
             "general_lighting_lux": round(self.base_mean, 2),
             "area_m2": round(g.area_m2, 3), "points": g.n_vertices}
        if g.kind == "spot":
            d.update({"pass": bool(self.ok), "tolerance": SPOT_TOLERANCE,
                      "accent": None if self.accent is None else self.accent.extra.get("type"),
                      "accent_watts": round(self.accent_watts, 2)})
        return d


def _candidates(droom, rs, radius, wp_top_z):
    """Allowed accent positions and facing normals of the room's mounting."""
    if rs.mounting.kind == "wall":
        return np.zeros((0, 3)), np.zeros((0, 3))
    s = np.arange(ACCENT_GRID_M / 2, droom.size[0], ACCENT_GRID_M)
    t = np.arange(ACCENT_GRID_M / 2, droom.size[1], ACCENT_GRID_M)
    plan = np.stack(np.meshgrid(s, t, indexing="ij"), axis=-1).reshape(-1, 2)
    pos, nrm, ok = mount(droom, plan, rs.mounting, radius, wp_top_z)
    return pos[ok], nrm[ok]


def _best_accent(goal, base, entries, photometry, positions, normals, mf, shade,
                 shade_base, shade_limit):
    """(entry index, position index, flux, watts) of the accent whose fast estimate meets
    the spot: of the least watts, or the closest shape within WATTS_SLACK of them; None."""
    need = np.maximum(goal.target - base, 0.0)
    tm = goal.target_mean
    found = []                                       # (watts, error, entry, position, flux)
    for k, e in enumerate(entries):
        phot = photometry.get(e.name)
        U = mf * unit_response(goal.points, goal.normals, positions, normals, e.radius_m,
                               phot)                                    # (k, P) lux/lm
        uu = np.einsum("kp,kp->p", U, U)
        f = np.where(uu > 0, (U.T @ need) / np.maximum(uu, 1e-30), 0.0)
        f = np.clip(f, e.dimming[0] * e.flux_lm, e.flux_lm)
        mean = np.mean(base) + f * U.mean(axis=0)
        ok = np.abs(mean - tm) <= SPOT_TOLERANCE * tm * 0.95            # margin for exact
        if shade is not None and len(shade[0]):
            S = mf * unit_response(shade[0], shade[1], positions, normals, e.radius_m, phot)
            ok &= np.max(shade_base[:, None] + S * f, axis=0) <= shade_limit
        watts = e.watts * f / e.flux_lm
        err = np.sqrt(np.mean((base[:, None] + U * f - goal.target[:, None]) ** 2, axis=0))
        found += [(watts[p], err[p], k, p, f[p]) for p in np.flatnonzero(ok)]
    if not found:
        return None
    w = np.array([x[0] for x in found])
    near = [x for x in found if x[0] <= w.min() * WATTS_SLACK]
    watts, _, k, p, flux = min(near, key=lambda x: (x[1], x[0]))
    return int(k), int(p), float(flux), float(watts)


def light_spots(model, droom, rs, entries, photometry, general, goals, wp_top_z, shade=None,
                shade_limit=5.0):
    """Add one accent luminaire to each spot the general lighting leaves too dark.

    Parameters
    ----------
    model : evaluate.RoomModel of the room
    general : list of Luminaire, the work-plane design
    goals : list of Goal (from :func:`find_goals`)
    shade : (points, normals) that must stay dark, optional

    Returns
    -------
    accents : list of Luminaire (``extra['role'] == 'accent'``)
    results : list of SpotResult, one per goal (surface goals included, for the report)
    """
    mf = model.mf
    accents = []
    radius = max(e.radius_m for e in entries)
    positions, normals = _candidates(droom, rs, radius, wp_top_z)
    # every receiver (the goals' points, then the shade points) in one array: one exact
    # solve for the general lighting, one per accent (light adds up, radiosity is linear)
    n_shade = len(shade[0]) if shade is not None else 0
    pts = np.concatenate([g.points for g in goals] + ([shade[0]] if n_shade else []))
    nrm = np.concatenate([g.normals for g in goals] + ([shade[1]] if n_shade else []))
    ends = np.cumsum([0] + [len(g.points) for g in goals])
    lux = model.exact_at(pts, nrm, general)
    general_lux = lux.copy()
    notes, accent_of = {}, {}
    for i, goal in enumerate(goals):
        base = lux[ends[i]:ends[i + 1]]
        wanted, note = accent_wanted(goal, base)
        if not wanted:
            if note:
                notes[i] = f"{goal.label()}: {note}"
            continue
        others = np.array([lum.position for lum in general + accents]).reshape(-1, 3)
        free = np.ones(len(positions), bool)
        if len(others) and len(positions):
            gap = np.linalg.norm(positions[:, None] - others[None], axis=2).min(axis=1)
            free = gap >= ACCENT_MIN_GAP_M
        shade_base = lux[ends[-1]:] if n_shade else None
        best = (_best_accent(goal, base, entries, photometry, positions[free], normals[free],
                             mf, shade, shade_base, shade_limit)
                if free.any() else None)
        if best is None:
            notes[i] = (f"{goal.label()}: no catalogue luminaire at an allowed position"
                        f" brings it from {np.mean(base):.0f} to {goal.target_mean:.0f} lx"
                        f" (+/- {SPOT_TOLERANCE:.0%})")
            continue
        k, p, flux, _ = best
        p = int(np.flatnonzero(free)[p])
        e = entries[k]
        own = model.exact_at(pts, nrm, [_accent(positions[p], normals[p], flux, entries, k,
                                               droom.room, photometry)])
        gain = float(np.mean(own[ends[i]:ends[i + 1]])) / flux       # exact lx per lm
        if not within(float(np.mean(base)) + gain * flux, goal.target_mean):
            # one exact correction of the flux (the fast estimate has no shadows and no
            # interreflection of its own light); its light scales with it
            want = (goal.target_mean - float(np.mean(base))) / max(gain, 1e-30)
            new = float(np.clip(want, e.dimming[0] * e.flux_lm, e.flux_lm))
            own, flux = own * (new / flux), new
        accents.append(_accent(positions[p], normals[p], flux, entries, k, droom.room,
                               photometry))
        accent_of[i] = (accents[-1], e.watts * flux / e.flux_lm)
        lux = lux + own
    # the figures of every goal with all the accents (a later accent may light an
    # earlier spot too)
    results = []
    for i, goal in enumerate(goals):
        lum, watts = accent_of.get(i, (None, 0.0))
        res = SpotResult(goal, float(np.mean(lux[ends[i]:ends[i + 1]])),
                         float(np.mean(general_lux[ends[i]:ends[i + 1]])), lum, watts,
                         notes.get(i, ""))
        if goal.kind == "spot" and lum is not None and not res.ok:
            res.note = (f"{goal.label()}: the best accent gives {res.achieved_mean:.0f} lx"
                        f" for {goal.target_mean:.0f} lx")
        results.append(res)
    return accents, results


def _accent(position, normal, flux, entries, k, room, photometry):
    lum = luminaires_of([position], [normal], [flux], entries, [k], room, photometry)[0]
    lum.extra["role"] = "accent"
    return lum

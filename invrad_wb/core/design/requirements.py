"""Locate on requirement targets: a regular layout of the given luminaire, not a picture fit.

An architect who asks for "300 lx on the work plane" states a *requirement*: a level with a
tolerance and the uniformity EN 12464-1 pairs with it, not a physically exact picture of
light. Fitting luminaires to such targets point by point (the inverted radiosity of
:mod:`invrad_wb.core.inverse.locate`) cannot succeed: no arrangement of real luminaires
gives a perfectly constant illuminance, and the best point-by-point fit puts lights on the
walls in rings (FZK-Haus with ``examples/fzk_targets.json``: 30 of 41 fixtures wall lights,
U0 0.31-0.57, no room within its targets).

:func:`classify` tells the two apart per room: *requirement* targets have a constant level on
a horizontal work plane and every other lit target surface is either a constant level too
(a uniformly lit wall: a goal, reported) or a small painted spot (an accent); a rendered or
measured picture never has a constant level over a plane, so it is *exact* and keeps the
inverted-radiosity recovery unchanged. A room whose work plane is a level but whose
surfaces carry a varying picture is *mixed* and is taken as exact.

:func:`design_requirements` lays out the given luminaire (its flux and photometry, no
dimming) in regular rows with the design engine (:mod:`.design`, a one-entry catalogue,
maintenance factor 1: the target is what the verification renders): on the ceiling, as
pendants where the ceiling is higher than :data:`PENDANT_ABOVE_M`, never on the walls; the
fewest luminaires whose mean on the work plane reaches the level with the uniformity of
:func:`~.en12464.uniformity_for`. Painted spots get accents as in a design.
"""
from dataclasses import dataclass, field

import numpy as np

from invrad_wb.core.output.fitquality import EM_HIGH, EM_LOW, requirement_verdict  # noqa: F401

#: a set of targets is a constant level when its spread is below this fraction of its max
LEVEL_TOLERANCE = 1e-6
#: a floor-parallel virtual face with a normal Z above this is part of a work plane
_UP = 0.99
#: ceilings higher than this above the floor (median over the floor) take pendants (m)
PENDANT_ABOVE_M = 4.0
#: pendants hang this far above the floor (m) under a high ceiling
PENDANT_HEIGHT_M = 3.0
#: pendant heights above the floor (m) tried under a sloped ceiling (after the ceiling)
PENDANT_HEIGHTS_M = (2.2, 2.5)
#: a pendant needs the ceiling at least this far above it (m); a ceiling whose height
#: varies by less than this is flat
PENDANT_CLEARANCE_M = 0.3
#: EN 12464-1: where the task positions are not known, the task area is the room less a
#: border zone of 0.5 m; a work plane targeted to the walls is judged (and laid out) there
EN_BORDER_M = 0.5
#: border zones are measured in steps of this (m), rounded down
_MARGIN_STEP_M = 0.05


@dataclass
class RoomTargets:
    """What a room's targets are.

    Attributes
    ----------
    room : int
    kind : 'requirement' or 'exact'
    reason : str, why, in words
    level_lux : float, the work plane's level (requirement rooms; else None)
    height_m : float, the work plane above the floor (m)
    margin_m : float, the work plane's border zone without targets (m)
    u0 : float, the uniformity required (EN 12464-1 for the level)
    u0_source : str, where ``u0`` comes from, e.g. 'EN 12464-1 for 500 lx'
    spots : int, painted spots (accents)
    surfaces : list of (words, lux), constant levels on real surfaces (goals)
    """
    room: int
    kind: str
    reason: str
    level_lux: float = None
    height_m: float = None
    margin_m: float = None
    u0: float = None
    u0_source: str = None
    spots: int = 0
    surfaces: list = field(default_factory=list)

    @property
    def requirement(self):
        return self.kind == "requirement"

    def to_dict(self):
        d = {"room": int(self.room), "targets": self.kind, "reason": self.reason}
        if self.requirement:
            d.update(level_lux=self.level_lux, height_m=round(self.height_m, 3),
                     margin_m=self.margin_m, u0_required=self.u0, u0_source=self.u0_source,
                     spots=self.spots,
                     surfaces=[{"surface": w, "lux": v} for w, v in self.surfaces])
        return d


def _constant(values):
    values = np.asarray(values, dtype=np.float64)
    return len(values) > 0 and float(np.ptp(values)) <= LEVEL_TOLERANCE * float(values.max())


def classify(scene, room, name=None):
    """The :class:`RoomTargets` of one room of ``scene`` (see the module docstring)."""
    label = name or f"room {room}"
    t = scene.vertex_targets() if scene.has_targets else np.full(len(scene.vertices), np.nan)
    lit = np.isfinite(t) & (t > 0)
    mine = scene.face_room == room
    wp_faces = mine & scene.face_virtual & (scene.face_normals[:, 2] > _UP)
    wp_v = np.unique(scene.faces[wp_faces])
    wp_lit = wp_v[lit[wp_v]]
    if not len(wp_lit):
        return RoomTargets(room, "exact", f"{label}: no work-plane level: its targets are"
                           " taken as exact light")
    if not _constant(t[wp_lit]):
        return RoomTargets(room, "exact", f"{label}: the work-plane targets vary"
                           f" ({t[wp_lit].min():.0f}-{t[wp_lit].max():.0f} lx): exact light")
    # only a room with a work-plane level needs the design modules: a locate run on exact
    # light does not import them (0.07-0.09 CPU s of every command-line run)
    from invrad_wb.core.design import en12464
    from invrad_wb.core.design.accent import find_goals
    from invrad_wb.core.design.room import DesignRoom
    surfaces, spots = [], 0
    for g in find_goals(scene, room):
        if g.kind == "spot":
            spots += 1
        elif _constant(g.target):
            surfaces.append((g.surface, float(g.target.max())))
        else:
            return RoomTargets(room, "exact", f"{label}: the work plane is a level but"
                               f" the {g.surface or 'surfaces'} carry a varying picture"
                               " (mixed targets): taken as exact light")
    droom = DesignRoom(scene, room, label)
    level = float(t[wp_lit].max())
    height = float(np.median(scene.vertices[wp_lit, 2])) - droom.floor_z
    dist = droom.wall_distance(scene.vertices[wp_lit, :2])
    margin = max(EN_BORDER_M,
                 np.floor(float(dist.min()) / _MARGIN_STEP_M + 1e-6) * _MARGIN_STEP_M)
    u0, source = en12464.uniformity_for(level)
    return RoomTargets(room, "requirement",
                       f"{label}: a level of {level:g} lx on the work plane"
                       + (f", {len(surfaces)} uniform surface(s)" if surfaces else "")
                       + (f", {spots} painted spot(s) as accents" if spots else "")
                       + ": a requirement", level, height, round(float(margin), 3), u0,
                       source, spots, surfaces)


def classify_rooms(scene, rooms=None, room_names=None):
    """``{room id: RoomTargets}`` for ``rooms`` (default every room of ``scene``)."""
    names = room_names or {}
    ids = scene.rooms if rooms is None else rooms
    return {int(r): classify(scene, int(r), names.get(int(r))) for r in ids}


def mountings(scene, room, label=None):
    """The mountings tried in a room, preferred first: pendants at :data:`PENDANT_HEIGHT_M`
    then the ceiling where the ceiling is high (:data:`PENDANT_ABOVE_M`); else the
    ceiling, then pendants at :data:`PENDANT_HEIGHTS_M` above the floor where the ceiling
    rises at least
    :data:`PENDANT_CLEARANCE_M` above them somewhere (high or sloped ceilings; a pendant
    is only placed where the ceiling is above it)."""
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.design.spec import Mounting
    droom = DesignRoom(scene, room, label)
    centres = droom.floor_tri.mean(axis=1)[:, :2]
    zc, _ = droom.ceiling_at(centres)
    zc = zc[np.isfinite(zc)]
    out = [Mounting("ceiling")]
    top = float(zc.max()) - droom.floor_z if len(zc) else 0.0
    flat = len(zc) and float(np.ptp(zc)) < PENDANT_CLEARANCE_M
    if len(zc) and float(np.median(zc)) - droom.floor_z > PENDANT_ABOVE_M:
        out.insert(0, Mounting("pendant", PENDANT_HEIGHT_M))     # a high ceiling: hang
    elif not flat:
        out += [Mounting("pendant", h) for h in PENDANT_HEIGHTS_M
                if top >= h + PENDANT_CLEARANCE_M]
    return out


def requirement_spec(scene, targets, flux_lm, room_names=None, mounting=None):
    """The design spec of requirement rooms: a one-entry catalogue of the given luminaire
    (``flux_lm`` at full output, not dimmable; its power is unknown and irrelevant: the
    count decides, so 'watts' stand in at 1 W per 100 lm), maintenance factor 1, per room
    the level with its EN 12464-1 uniformity on the targets' work plane, mounted as
    ``mounting[room]`` (default: the ceiling)."""
    from invrad_wb.core.design.spec import (CatalogueEntry, DesignSpec, Mounting, RoomSpec,
                                            WorkPlaneRequirement)
    entry = CatalogueEntry(f"{flux_lm:g} lm luminaire", float(flux_lm), float(flux_lm) / 100.0,
                           mounting=("ceiling", "pendant"))
    rooms = {}
    for r, rt in targets.items():
        if not rt.requirement:
            continue
        req = WorkPlaneRequirement(rt.level_lux, rt.u0, rt.height_m, rt.margin_m,
                                   source=rt.u0_source)
        rooms[str(r)] = RoomSpec(str(r), req, mounting=(mounting or {}).get(r, Mounting()))
    return DesignSpec(1.0, [entry], rooms, source="locate requirements")


def _score(rd):
    """How close a room's design comes to its requirement (>= 1: met; None: no design)."""
    if rd.metrics is None:
        return None
    r, m = rd.requirement, rd.metrics
    return min(m.em / r.lux, m.u0 / max(r.u0, 1e-9))


def _dim_if_too_bright(rd, flux_lm):
    """Where even the chosen layout (the fewest luminaires that spread the light evenly
    enough) gives more than :data:`EM_HIGH` x the level at full output, dim the room's
    luminaires together to the level (light is linear in flux; U0 does not change), and
    say so: the given luminaire is too strong for the room."""
    r, m = rd.requirement, rd.metrics
    if m is None or m.em <= EM_HIGH * r.lux:
        return 1.0
    f = r.lux * 1.001 / m.em
    for lum in rd.luminaires:
        lum.flux_lm = float(flux_lm) * f
        lum.extra["dim"] = round(f, 4)
    from invrad_wb.core.design.search import Metrics
    rd.metrics = Metrics(m.em * f, m.emin * f, m.emax * f, m.u0, m.shade_max * f,
                         None if m.lux is None else m.lux * f,
                         None if m.direct is None else m.direct * f)
    # the design's "the catalogue has nothing weaker" note: said better below
    rd.notes[:] = [n for n in rd.notes if not n.startswith(f"Em {m.em:.0f} lx is")]
    rd.notes.append(f"dimmed to {100 * f:.0f} %: at full output the fewest luminaires that"
                    f" light the room evenly give {m.em:.0f} lx for {r.lux:g} lx (a weaker"
                    " luminaire would do without dimming)")
    return f


@dataclass
class RequirementsResult:
    """Requirement rooms laid out by the design engine.

    ``rooms``: {room id: RoomDesign}; ``targets``: {room id: RoomTargets};
    ``luminaires``: every room's luminaires (``extra['mount']`` 'surface' or 'pendant').
    """
    rooms: dict
    targets: dict
    luminaires: list
    seconds: float = 0.0
    mountings: dict = field(default_factory=dict)


def design_requirements(scene, targets, flux_lm, photometry=None, backend="auto",
                        room_names=None, progress=None, workers=1):
    """Regular layouts of the given luminaire in the requirement rooms of ``targets``
    (``{room id: RoomTargets}``, from :func:`classify_rooms`).

    Each room is designed on the ceiling first; where that does not meet the level and
    the ceiling is high or sloped, as pendants (:func:`mountings`); the first mounting
    that meets it is kept, else the closest. A layout too bright even with its fewest
    luminaires is dimmed to the level (:func:`_dim_if_too_bright`).

    Returns
    -------
    RequirementsResult
    """
    import time
    from invrad_wb.core.design.design import design
    from invrad_wb.core.design.room import DesignRoom
    t0 = time.perf_counter()
    req_ids = [r for r, rt in targets.items() if rt.requirement]
    if not req_ids:
        return RequirementsResult({}, targets, [], 0.0)
    sub = scene if len(scene.rooms) == len(req_ids) else scene.face_subset(
        np.flatnonzero(np.isin(scene.face_room, req_ids)))
    names = {r: (room_names or {}).get(r) for r in req_ids}
    options = {r: mountings(sub, r, names[r]) for r in req_ids}
    best, chosen = {}, {}
    todo = list(req_ids)
    for k in range(max(len(o) for o in options.values())):
        rooms_k = [r for r in todo if k < len(options[r])]
        if not rooms_k:
            break
        mount = {r: options[r][k] for r in rooms_k}
        spec = requirement_spec(sub, {r: targets[r] for r in rooms_k}, flux_lm, names, mount)
        entry = spec.catalogue[0]
        phot = {entry.name: photometry} if photometry is not None else {}
        part = sub if len(rooms_k) == len(sub.rooms) else sub.face_subset(
            np.flatnonzero(np.isin(sub.face_room, rooms_k)))
        res = design(part, spec, room_names={r: names[r] for r in rooms_k}, backend=backend,
                     progress=progress if k == 0 else None, workers=workers, mixed=False,
                     dimming=False, photometry=phot)
        for rd in res.rooms:
            r = int(rd.room)
            sc = _score(rd)
            if r not in best or (sc is not None and (best[r][0] is None or sc > best[r][0])):
                best[r], chosen[r] = (sc, rd), mount[r]
        todo = [r for r in todo if best[r][0] is None or best[r][0] < 1.0 - 1e-9]
        if not todo:
            break
    rooms, lums = {}, []
    for r in req_ids:
        rd = best[r][1]
        rooms[r] = rd
        _dim_if_too_bright(rd, flux_lm)
        pendant = chosen[r].kind == "pendant"
        if pendant:
            rd.notes.append(f"pendants {chosen[r].height_m:g} m above the floor: on the"
                            " ceiling the level is not met")
        hung = np.zeros(len(rd.luminaires), dtype=bool)
        if rd.luminaires and not pendant:      # under a slab opening: hung, no ceiling
            xy = np.array([lum.position[:2] for lum in rd.luminaires])
            hung = DesignRoom(sub, r, names[r]).no_mount_at(xy)[1]
            if hung.any():
                rd.notes.append(f"{int(hung.sum())} pendant(s) under the slab opening"
                                " above (no ceiling there)")
        for lum, h in zip(rd.luminaires, hung):
            lum.extra["mount"] = "pendant" if pendant or h else "surface"
            lum.extra["layout"] = "requirement"
            lums.append(lum)
    return RequirementsResult(rooms, targets, lums, time.perf_counter() - t0,
                              {r: chosen[r] for r in req_ids})


def judge(scene, room, rt, achieved, name=None):
    """The :class:`~invrad_wb.core.output.fitquality.RequirementVerdict` of a requirement
    room, as EN 12464-1 judges: the achieved lux (per vertex of ``scene``, e.g. a forward
    render) interpolated at the calculation grid of the task area (the work plane less
    its border zone ``rt.margin_m``, cell centres at most ``p = 0.2 * 5^log10(d)`` apart:
    :meth:`~invrad_wb.core.design.room.DesignRoom.grid`) and checked against the level
    and the uniformity of ``rt``. Without such grid points, the work-plane vertices of
    the task area are judged."""
    from invrad_wb.core.design.room import DesignRoom
    from invrad_wb.core.geometry.raster import locate_points
    t = scene.vertex_targets()
    achieved = np.asarray(achieved, dtype=np.float64)
    wp_faces = np.flatnonzero((scene.face_room == room) & scene.face_virtual
                              & (scene.face_normals[:, 2] > _UP))
    tri = scene.faces[wp_faces]
    droom = DesignRoom(scene, room, name)
    try:
        points, _ = droom.grid(rt.height_m, rt.margin_m)
    except Exception:          # noqa: BLE001 - no grid: judge the vertices below
        points = np.zeros((0, 3))
    if len(points) and len(tri):
        idx, bary = locate_points(scene.vertices[tri][..., :2], points[:, :2])
        ok = idx >= 0
        if ok.any():
            corners = tri[idx[ok]]
            lit = np.all(np.isfinite(t[corners]) & (t[corners] > 0), axis=1)
            values = np.einsum("ij,ij->i", bary[ok], achieved[corners])[lit]
            if len(values):
                return requirement_verdict(rt.level_lux, values, rt.u0, rt.u0_source)
    v = np.unique(tri)
    v = v[np.isfinite(t[v]) & (t[v] > 0)]
    inside = droom.wall_distance(scene.vertices[v, :2]) >= rt.margin_m - 1e-6
    v = v[inside] if inside.any() else v
    return requirement_verdict(rt.level_lux, achieved[v], rt.u0, rt.u0_source)


def verdict_summary(scene, room, rt, achieved, name, result, advice):
    """A requirement room's verdict as a dict (Locate's and the CLI's summaries): the
    :func:`judge` verdict, its words, the layout, mounting and notes of the room's design in
    ``result`` (a :class:`RequirementsResult`, or None) and, where not met, why not and the
    ``advice`` (which words name Design depends on who asks)."""
    v = judge(scene, room, rt, achieved, name)
    d = {"targets": "requirement", **v.to_dict(), "words": f"{name}: {v.words()}"}
    rd = None if result is None else result.rooms.get(room)
    if rd is not None and rd.candidate is not None:
        d["layout"] = rd.candidate.geom.describe()
        d["mounting"] = result.mountings[room].kind
        d["notes"] = [n for n in rd.notes if "nothing designed" not in n]
    if not v.met:
        d["why_not"] = v.why_not()
        d["advice"] = advice
    return d

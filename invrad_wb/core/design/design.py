"""Lighting design from requirements: every room of a scene, least installed watts.

``design(scene, spec)`` takes a scene (rooms with reflectances; targets optional) and a
:class:`~invrad_wb.core.design.spec.DesignSpec`, and returns a :class:`DesignResult`: per
room the chosen luminaires (catalogue type, position, facing, flux after dimming), the
exact maintained figures on the EN 12464-1 grid (Em, Emin, Emax, U0), pass/fail of each
requirement, installed watts and W/m^2, and a plain-language explanation where the
catalogue cannot meet a requirement (the closest design is returned then).
"""
from dataclasses import dataclass, field
import time

import numpy as np

from invrad_wb.constants import DEEP_DIMMING
from invrad_wb.errors import Cancelled, SettingsError
from invrad_wb.core.accel.workers import map_rooms
from invrad_wb.core.design.background import with_background
from invrad_wb.core.design.dimnotes import deep_dimming_note
from invrad_wb.core.design.evaluate import RoomModel, surface_grids
from invrad_wb.core.design.refine import refine
from invrad_wb.core.design.room import DesignRoom
from invrad_wb.core.design.roomglare import glare_parts, room_ugr, ugr_at, ugr_note
from invrad_wb.core.design.accent import SPOT_TOLERANCE, find_goals, light_spots, within
from invrad_wb.core.design.accentglare import beside_accents
from invrad_wb.core.design.accents import light_spots_aimed
from invrad_wb.core.design.taskareas import check_task_areas
from invrad_wb.core.design.taskareas import prepare as prepare_task_areas
from invrad_wb.core.design.search import (Candidate, Metrics, RoomSearch, classic_grids,
                                          margin_kept, metrics_comply, run_search)

#: shade points per room at most (deterministic subsample beyond)
MAX_SHADE_POINTS = 2000


@dataclass
class RoomDesign:
    room: int
    name: str
    requirement: object
    luminaires: list
    metrics: object = None
    candidate: object = None
    area_m2: float = 0.0
    size_m: tuple = (0.0, 0.0)
    grid_points: np.ndarray = field(default=None, repr=False)
    notes: list = field(default_factory=list)
    exact_solves: int = 0
    seconds: float = 0.0
    reflectance: dict = field(default_factory=dict)
    outline: np.ndarray = field(default=None, repr=False)   # (k, 2, 2) walls in plan, m
    floor_z: float = 0.0
    ugr: float = None            # CIE 117, worst standard observer (None: not computable)
    ugr_limit: float = None
    surface_reqs: dict = field(default_factory=dict)   # 'walls'/'ceiling' -> requirement
    rated_watts: float = 0.0     # installed power: every luminaire at full output (W)
    operating_hours: float = None   # h/a, for the energy estimate
    cylindrical: dict = None     # Ez asked for ({'lux', 'u0', 'height_m'}) or None
    cyl_figures: dict = None     # Ez achieved (cylindrical.figures) or None
    spots: list = field(default_factory=list)      # accent.SpotResult, spots and goals
    accent_watts: float = 0.0
    background_words: str = None  # why the background area is not judged (background.py)

    @property
    def watts(self):
        return 0.0 if self.candidate is None else self.candidate.watts + self.accent_watts

    @property
    def w_per_m2(self):
        """Installed (rated) power density, W/m^2."""
        return self.rated_watts / max(self.area_m2, 1e-9)

    @property
    def w_per_m2_100lx(self):
        """Installed power density per 100 lx of maintained Em (W/m^2/100 lx)."""
        if self.metrics is None or self.metrics.em <= 0:
            return None
        return self.w_per_m2 / (self.metrics.em / 100.0)

    def general_outputs(self):
        """Each general luminaire's output (fraction of its rated flux), in the order of
        ``luminaires`` (accents, appended after them, are not general lighting): one
        level where the type is dimmed evenly, each luminaire's own where its rows are
        dimmed apart (:mod:`.refine`)."""
        c = self.candidate
        if c is None:
            return np.zeros(0)
        n = len(c.geom.positions)
        if getattr(c, "dims", None) is not None:
            return np.asarray(c.dims, dtype=float)[:n]
        return np.full(n, float(c.dim))

    def deep_dimmed(self):
        """{type: (luminaires below ``DEEP_DIMMING``, luminaires of that type)} of the
        general lighting, types with none below left out."""
        out = {}
        for lum, x in zip(self.luminaires, self.general_outputs()):
            t = lum.extra.get("type")
            low, n = out.get(t, (0, 0))
            out[t] = (low + int(x < DEEP_DIMMING - 1e-9), n + 1)
        return {t: v for t, v in out.items() if v[0]}

    @property
    def deep_dimming(self):
        """Some general luminaire runs below ``DEEP_DIMMING`` of its rated output (each
        luminaire's own output counts, not its type's mean)."""
        return bool(self.deep_dimmed())

    @property
    def energy_kwh(self):
        """Energy per year at the designed output (kWh/a; None without operating hours):
        LENI style, W = P t / 1000, no daylight, occupancy or parasitic terms."""
        if self.operating_hours is None or self.candidate is None:
            return None
        return self.watts * self.operating_hours / 1000.0

    @property
    def verdicts(self):
        """{'Em': bool, 'U0': bool, 'shade': bool} (empty without a requirement)."""
        if self.metrics is None:
            return {}
        r, m = self.requirement, self.metrics
        out = {"Em": m.em >= r.lux - 1e-9, "U0": m.u0 >= r.u0 - 1e-9,
               "shade": bool((self.candidate.ok and not self.accent_watts)
                             or m.shade_max <= self._shade_limit)}
        spots = [s for s in self.spots if s.goal.kind == "spot"]
        if spots:
            out["spots"] = all(s.ok for s in spots)
        if getattr(r, "task_areas", ()):      # each task area judged on its own cells (surface_ok)
            del out["Em"], out["U0"]
        out.update(m.surface_ok(self.surface_reqs))
        if self.cylindrical is not None and self.cyl_figures is not None:
            from invrad_wb.core.design.cylindrical import complies as cyl_complies
            out["Ez"] = cyl_complies(self.cyl_figures, self.cylindrical)
        if self.ugr_limit is not None and self.ugr is not None:
            out["UGR"] = self.ugr <= self.ugr_limit + 1e-9
        return out

    _shade_limit = 5.0

    @property
    def compliant(self):
        return bool(self.verdicts) and all(self.verdicts.values())

    def schedule(self):
        """Luminaire schedule: {type: (count, lm each at full output, W each, dim)}."""
        out = {}
        for lum in self.luminaires:
            t = lum.extra.get("type")
            out.setdefault(t, 0)
            out[t] += 1
        return out

    def type_outputs(self):
        """{type: mean output fraction of that type's general luminaires} (their lumens
        over the lumens at full output: one figure per type where outer and inner rows
        are dimmed apart, :mod:`.refine`)."""
        if self.candidate is None:
            return {}
        if getattr(self.candidate, "dims", None) is None:
            return {t: self.candidate.dim for t in self.schedule()}
        full, got = {}, {}
        for lum, d in zip(self.luminaires, self.candidate.dims):
            t = lum.extra.get("type")
            full[t] = full.get(t, 0.0) + lum.flux_lm / max(d, 1e-12)
            got[t] = got.get(t, 0.0) + lum.flux_lm
        return {t: got[t] / full[t] for t in full}

    def _turned(self):
        """', C0 along the room' (or across) where the chosen type was turned."""
        o = sorted({lum.extra["orientation"] for lum in self.luminaires
                    if lum.extra.get("orientation")})
        return "".join(f", C0 {x} the room" for x in o)

    def to_dict(self):
        d = {"room": self.room, "name": self.name, "area_m2": round(self.area_m2, 3),
             "size_m": [round(float(x), 3) for x in self.size_m],
             "reflectance": self.reflectance, "notes": self.notes,
             "exact_solves": self.exact_solves, "seconds": round(self.seconds, 3)}
        if self.requirement is not None:
            d["requirement"] = self.requirement.to_dict()
        if self.metrics is not None:
            m = self.metrics
            d.update({"em_lux": round(m.em, 2), "emin_lux": round(m.emin, 2),
                      "emax_lux": round(m.emax, 2), "u0": round(m.u0, 6),
                      "shade_max_lux": round(m.shade_max, 3),
                      "pass": {k: bool(v) for k, v in self.verdicts.items()},
                      "compliant": self.compliant, "watts": round(self.watts, 2),
                      "w_per_m2": round(self.watts / max(self.area_m2, 1e-9), 3),
                      "layout": self.candidate.geom.describe() + self._turned(),
                      "dim": round(self.candidate.dim, 4),
                      "ugr": None if self.ugr is None else round(self.ugr, 1),
                      "ugr_limit": self.ugr_limit,
                      "grid_points": int(self.metrics.lux is not None and
                                         len(self.grid_points))})
            d["surfaces"] = {
                k: {"em_lux": round(v[0], 2), "emin_lux": round(v[1], 2),
                    "u0": round(v[2], 6),
                    **({"required": self.surface_reqs[k].to_dict()}
                       if k in self.surface_reqs else {})}
                for k, v in m.surfaces.items()}
            if getattr(self.requirement, "task_areas", ()):    # each judged on its own cells
                from invrad_wb.core.design.spec import part_name
                d["task_areas"] = [
                    {**ta.to_dict(), "area_m2": round(ta.area_m2, 3),
                     **d["surfaces"].get(part_name(ta.name), {}),
                     "pass": bool(self.verdicts.get(part_name(ta.name)))}
                    for ta in self.requirement.task_areas]
            if not any(k.startswith("background") for k in self.surface_reqs):
                d["background"] = {"judged": False, "why": self.background_words}
            if self.cylindrical is not None:
                d["cylindrical"] = {"required": dict(self.cylindrical),
                                    "judged": self.cyl_figures is not None}
                if self.cyl_figures is not None:
                    # U0 to 6 places, as the work plane's: read to 2 places once
                    d["cylindrical"].update({k: (None if v is None else
                                                 round(v, 6 if k == "u0" else 3))
                                             for k, v in self.cyl_figures.items()})
                    d["cylindrical"]["pass"] = bool(self.verdicts.get("Ez"))
            d["power"] = {
                "designed_w": round(self.watts, 2), "rated_w": round(self.rated_watts, 2),
                "rated_w_per_m2": round(self.w_per_m2, 3),
                "rated_w_per_m2_100lx": (None if self.w_per_m2_100lx is None
                                         else round(self.w_per_m2_100lx, 3)),
                "output_percent": round(100 * self.candidate.dim, 1),
                "deep_dimming": bool(self.deep_dimming),   # numpy's after re-dimming
                "operating_hours": self.operating_hours,
                "energy_kwh_per_year": (None if self.energy_kwh is None
                                        else round(self.energy_kwh, 1)),
                "leni_kwh_per_m2_year": (None if self.energy_kwh is None else
                                         round(self.energy_kwh / max(self.area_m2, 1e-9),
                                               2))}
            d["schedule"] = self.schedule()
            d["accent_watts"] = round(self.accent_watts, 2)
            d["spots"] = [s.to_dict() for s in self.spots]
        return d


@dataclass
class DesignResult:
    rooms: list
    spec: object
    timings: dict = field(default_factory=dict)

    @property
    def luminaires(self):
        return [lum for r in self.rooms for lum in r.luminaires]

    def write_report(self, out_dir, title="Lighting design", project=None):
        """The client's report (HTML, CSV, plans) in ``out_dir``; returns index.html."""
        from invrad_wb.core.output.design_report import write_design_report
        return write_design_report(self, out_dir, title=title, project=project)

    @property
    def watts(self):
        return sum(r.watts for r in self.rooms)

    @property
    def rated_watts(self):
        return sum(r.rated_watts for r in self.rooms)

    @property
    def energy_kwh(self):
        """kWh/a of the rooms with operating hours (None if none has)."""
        e = [r.energy_kwh for r in self.rooms if r.energy_kwh is not None]
        return sum(e) if e else None

    @property
    def compliant(self):
        return all(r.compliant for r in self.rooms if r.requirement is not None)

    def name_groups(self):
        """Give each luminaire of a room dimmed apart its dimming group's letter
        (``extra['dimming_group']``, as the report's plans and schedule letter it:
        :func:`invrad_wb.core.output.groups.output_groups`), so that the result JSON, the
        FreeCAD fixtures and the IFC name it too; a room at one output per type gets none."""
        from invrad_wb.core.output.groups import output_groups
        for r in self.rooms:
            if r.metrics is None:
                continue
            for g in output_groups(r, self.spec.catalogue):
                for i in g["members"]:
                    if g["label"]:
                        r.luminaires[i].extra["dimming_group"] = g["label"]
                    else:
                        r.luminaires[i].extra.pop("dimming_group", None)

    def to_dict(self):
        from invrad_wb.core.output.groups import groups_json
        lums, rooms = [], []
        for r in self.rooms:
            d = r.to_dict()
            if r.metrics is not None:      # its dimming groups (the report's letters)
                d["groups"] = groups_json(r, self.spec.catalogue, len(lums))
            lums += [lum.to_dict() for lum in r.luminaires]
            rooms.append(d)
        return {"luminaires": lums,
                "rooms": rooms,
                "maintenance_factor": self.spec.maintenance_factor,
                "design_margin": getattr(self.spec, "design_margin", 0.0),
                "catalogue": [e.to_dict() for e in self.spec.catalogue],
                "total_watts": round(self.watts, 2),
                "total_rated_watts": round(self.rated_watts, 2),
                "energy_kwh_per_year": (None if self.energy_kwh is None
                                        else round(self.energy_kwh, 1)),
                "compliant": self.compliant,
                "timings": {k: round(v, 3) for k, v in self.timings.items()}}


def _room_names(scene, room_names):
    ids = [int(r) for r in scene.rooms]
    if room_names is None:
        return {r: None for r in ids}
    if isinstance(room_names, dict):
        return {r: room_names.get(r) for r in ids}
    return {r: (room_names[r] if r < len(room_names) else None) for r in ids}


def check_rooms(spec, names):
    """Refuse spec room keys that name no room of the scene."""
    known = {str(r) for r in names} | {n for n in names.values() if n}
    for key in spec.rooms:
        if key != "*" and key not in known:
            shown = ", ".join(sorted(known, key=str)[:12])
            raise SettingsError(f"{spec.source}: rooms: {key!r} is not a room of the scene"
                                f" (rooms: {shown})")


def _shade_points(scene, room):
    """Vertices of the room that must stay dark (target 0 lx): points and normals."""
    if not scene.has_targets:
        return np.zeros((0, 3)), np.zeros((0, 3))
    t = scene.vertex_targets()
    real = np.zeros(len(scene.vertices), bool)
    sel = (scene.face_room == room) & ~scene.face_virtual
    real[np.unique(scene.faces[sel])] = True
    idx = np.flatnonzero(real & (t == 0))
    if len(idx) > MAX_SHADE_POINTS:
        idx = idx[np.linspace(0, len(idx) - 1, MAX_SHADE_POINTS).astype(int)]
    return scene.vertices[idx], scene.vertex_normals[idx]


def _explain(rd, search, entries):
    """Plain-language notes on a non-compliant or wasteful design."""
    r, m, c = rd.requirement, rd.metrics, rd.candidate
    if m.em < r.lux and not getattr(r, "task_areas", ()):
        strongest = max(entries, key=lambda e: e.flux_lm)
        rd.notes.append(f"too dark: the closest design gives Em {m.em:.0f} lx of the"
                        f" {r.lux:.0f} lx required with {len(rd.luminaires)} luminaires;"
                        f" the catalogue's strongest entry is {strongest.name}"
                        f" ({strongest.flux_lm:.0f} lm)")
    if m.u0 < r.u0 and not getattr(r, "task_areas", ()):
        rd.notes.append(f"uniformity U0 {m.u0:.2f} is below the required {r.u0:.2f}:"
                        " no layout of the catalogue's luminaires spreads the light evenly"
                        " enough at the mounting allowed")
    if rd.ugr is not None and rd.ugr_limit is not None and rd.ugr > rd.ugr_limit:
        rd.notes.append(f"UGR {rd.ugr:.1f} exceeds the limit {rd.ugr_limit:g}: choose"
                        " luminaires with less luminance towards the eye (louvres, larger"
                        " luminous area)")
    for name, ok in m.surface_ok(rd.surface_reqs).items():
        if not ok:
            q, (em, _, u0) = rd.surface_reqs[name], m.surfaces[name]
            rd.notes.append(f"{name}: Em {em:.0f} lx, U0 {u0:.2f} for {q.lux:g} lx,"
                            f" U0 {q.u0:g} required ({q.source}): no layout of the"
                            " catalogue's luminaires at the mounting allowed lights them"
                            " enough")
    if rd.verdicts.get("Ez") is False:
        f, q = rd.cyl_figures, rd.cylindrical
        rd.notes.append(f"cylindrical illuminance Ez {f['em_lux']:.0f} lx, U0 {f['u0']:.2f}"
                        f" at {q['height_m']:g} m for {q['lux']:g} lx, U0 {q['u0']:g}"
                        " required: no layout of the catalogue's luminaires at the mounting"
                        " allowed sends enough light sideways (wider beams, or wall lighting,"
                        " raise Ez)")
    if m.shade_max > search.rs.shade_limit_lux:
        rd.notes.append(f"a point that must stay dark receives {m.shade_max:.1f} lx"
                        f" (limit {search.rs.shade_limit_lux:g} lx)")
    if rd.deep_dimming:
        rd.notes.append(deep_dimming_note(rd, entries))
    # with task areas, the least excess over them (each against its own Em: the union's
    # Em against the work plane's lux compares different things)
    over = [(m.surfaces[a.part][0], rd.surface_reqs[a.part].lux)
            for a in getattr(r, "task_areas", ())
            if a.part in m.surfaces and a.part in rd.surface_reqs]
    em, lux = min(over, key=lambda x: x[0] / x[1]) if over else (m.em, r.lux)
    if c.ok and em > 1.5 * lux and c.dim >= 1.0:
        weakest = min(entries, key=lambda e: e.flux_lm)
        what = "" if not over else (" on the task areas" if len(over) == 1 else
                                    " on the task area least above its own")
        rd.notes.append(f"Em {em:.0f} lx{what} is {em / lux:.1f} x the {lux:.0f} lx"
                        f" required: fewer luminaires would not be uniform enough and the"
                        f" catalogue has nothing weaker than {weakest.name}"
                        f" ({weakest.flux_lm:.0f} lm) or dimmable")


def design_room(scene, spec, room, name=None, backend="auto", mixed=True, dimming=True,
                fractions=None, photometry=None):
    """Design one room (see :func:`design`); returns a :class:`RoomDesign`."""
    t0 = time.perf_counter()
    rs = spec.room_spec(room, name)
    label = name or f"room {room}"
    droom = DesignRoom(scene, room, label)
    rd = RoomDesign(room, label, None, [], area_m2=droom.floor_area,
                    size_m=tuple(droom.size), reflectance=_reflectances(scene, room),
                    outline=droom._edges, floor_z=droom.floor_z)
    if rs is None or rs.work_plane is None:
        rd.notes.append("no lighting requirement for this room: nothing designed")
        return rd
    req = rd.requirement = rs.work_plane
    if getattr(req, "task_areas", ()):     # the desks, a counter given explicitly (taskareas.py); the
        # search takes their union's cells and judges each area as a surface grid
        surfaces = surface_grids(scene, room, droom, backend=backend)
        points, rs, req = prepare_task_areas(rs, droom, req, surfaces, rd)
    else:
        points, _ = droom.grid(req.height_m, req.margin_m)
        surfaces = surface_grids(scene, room, droom, backend=backend)
        rs = _with_surroundings(rs, droom, req, surfaces, rd)
        rs = with_background(rs, droom, req, surfaces, rd)
    rd.surface_reqs = {k: v for k, v in rs.surfaces.items() if k in surfaces}
    rd.cylindrical = rs.cylindrical
    model = RoomModel(scene, droom, points, spec.maintenance_factor, backend,
                      extra=_shade_points(scene, room), surfaces=surfaces)
    cyl = _cylindrical_grid(model, droom, req, rs, rd, points)
    mount_h = (rs.mounting.height_m if rs.mounting.kind != "ceiling"
               else droom.top_z - droom.floor_z)
    entries = spec.entries_for(rs, mount_h)
    if not entries:
        rd.notes.append(f"no catalogue entry may be mounted at {mount_h:.2f} m"
                        f" ({rs.mounting.kind}): nothing designed")
        return rd
    if photometry is None:
        from invrad_wb.core.model.photometry import read_photometry
        photometry = {e.name: read_photometry(e.photometry) for e in entries if e.photometry}
    # aimable entries (adjustable spots) are for accents when the room has others
    general = [e for e in entries if not e.aimable] or entries
    search = RoomSearch(model, req, rs, general, photometry, mixed=mixed, dimming=dimming,
                        fractions=fractions)
    search.margin = spec.design_margin
    if cyl is not None:
        search.cylindrical, search.cyl_req = cyl, cyl.req
    if not search.geoms:
        rd.notes.append(f"no position in this room suits a {rs.mounting.kind} mounting")
        return rd
    cand, met, n_exact = run_search(search)
    tries = [(cand, met)]
    if cand is not None:
        # the regular grids a lighting designer would lay (one type, half spacing at the
        # walls, per rectangle of the room): the design never draws more than the best
        grid = classic_grids(search)
        n_exact = len(search.checked)
        if grid is not None and (not cand.ok or grid[0].watts < cand.watts - 1e-9):
            tries.insert(0, grid)
            cand, met = grid
        # the same and the next cheapest layouts with their outer and inner rows dimmed
        # apart, where the types dim (a linear programme on the exact model)
        refined, rmet, n_lp = refine(search, cand, met, [grid] if grid else [])
        n_exact += n_lp
        if refined is not cand:
            tries.insert(0, (refined, rmet))
    notes = list(rd.notes)
    # the room with its general lighting designed again for the accents' glare (once:
    # its programme searches beyond the layout it starts from)
    again, tried = None, False

    def finish(c, m, n):
        _finish_room(scene, rd, model, droom, rs, entries, photometry, req, search,
                     general, points, cyl, c, m, n)
    for c, m in tries:
        # the programme knows the general lighting only: accents (painted spots) add
        # light and glare, which may take a design dimmed apart, made to the limits,
        # below U0 or over the UGR limit; then the search's evenly dimmed design stands
        rd.notes, rd.spots, rd.accent_watts = list(notes), [], 0.0
        finish(c, m, n_exact)
        if rd.compliant:
            break
        if not tried and rd.verdicts.get("UGR") is False:
            tried = True
            again = beside_accents(rd, search, c, m, finish, notes)
    if again is not None and (not rd.compliant or again["candidate"].watts
                              + again["accent_watts"] < rd.watts - 1e-9):
        vars(rd).update(again)
    rd.rated_watts = sum(_entry_watts(entries, lum) for lum in rd.luminaires)
    rd.operating_hours = rs.operating_hours
    _explain(rd, search, general)
    rd.seconds = time.perf_counter() - t0
    return rd


def _finish_room(scene, rd, model, droom, rs, entries, photometry, req, search, general,
                 points, cyl, cand, met, n_exact):
    """The room's design from the search's layout ``cand``: its luminaires, the painted
    spots' accents, Ez and UGR of the whole installation."""
    rd.candidate, rd.metrics, rd.exact_solves = cand, met, n_exact
    rd.luminaires = search.luminaires(cand)
    if cand.dims is not None and np.ptp(cand.dims) > 1e-6:
        rd.notes.append(f"outer and inner rows dimmed apart: outputs"
                        f" {100 * cand.dims.min():.0f} to {100 * cand.dims.max():.0f} %"
                        " (each luminaire carries its own lumens; the schedule has a row"
                        " per output group; one common level would draw more)")
    rd.grid_points = points
    rd._shade_limit = rs.shade_limit_lux
    _light_goals(scene, rd, model, droom, rs, entries, photometry, req, search)
    if cyl is not None:       # the whole installation's (accents included)
        from invrad_wb.core.design.cylindrical import figures, modelling_note
        rd.cyl_figures = figures(*cyl.evaluate(rd.luminaires))
        note = modelling_note(rd.cyl_figures)
        if note:
            rd.notes.append(note)
    rd.ugr_limit = rs.ugr_max
    rd.ugr = room_ugr(model, droom, rd.luminaires)
    ugr_note(rd, droom)


#: re-dimming after accents tries the general lighting's output in this many steps
REDIM_STEPS = 200
#: re-dimming after accents confirms UGR on the whole installation at most this often
REDIM_UGR_CHECKS = 12
#: a spot met before re-dimming must stay within this share of its tolerance
REDIM_SPOT_MARGIN = 0.9


def _dimmed(cand, f, met=None):
    """The layout ``cand`` with every general luminaire's output times ``f`` (its
    figures from ``met`` where given, else kept)."""
    em, u0, shade = ((met.em, met.u0, met.shade_max) if met is not None
                     else (cand.em, cand.u0, cand.shade_max))
    return Candidate(cand.geom, cand.entries, cand.dim * f, cand.watts * f, em, u0, shade,
                     True, dims=None if cand.dims is None else cand.dims * f)


def _redim_with_accents(rd, model, droom, search, parts, accents, req, rs):
    """Accents add light to the work plane too: dim the general lighting (within its
    entries' dimming range) as far as every requirement still holds with the accents:
    Em, U0, shade, each spot that was met, and UGR (the accents' glare stands out as the
    general lighting and the background luminance it gives are dimmed). Light adds up (radiosity is linear), so the
    exact solves of the two ``parts`` ((lux, direct) of the general lighting, of the
    accents) give every dimming level."""
    cand = rd.candidate
    if cand is None:
        return
    e0, e1 = (search.entries[k] for k in cand.entries)
    floor = max(e0.dimming[0], e1.dimming[0]) if search.dimming else 1.0
    lowest = cand.dim if cand.dims is None else float(np.min(cand.dims))
    if lowest <= floor + 1e-9:
        return
    (G, Gd), (A, Ad) = parts
    spots = [sp for sp in rd.spots if sp.goal.kind == "spot"]
    glare = (glare_parts(model, droom, search.luminaires(cand), accents)
             if rs.ugr_max is not None else None)
    exact_left = REDIM_UGR_CHECKS
    if glare is not None:
        # dimming may not take UGR over the limit, nor (where the accents' glare is over
        # it at full output already) above what full output gives
        full = room_ugr(model, droom, search.luminaires(cand) + accents)
        cap = rs.ugr_max if full is None else max(rs.ugr_max, full)
    for f in np.linspace(floor / lowest, 1.0, REDIM_STEPS + 1):
        met = Metrics.of(f * G + A, f * Gd + Ad, model.layout)
        if (met.em < req.lux * 1.001 or not metrics_comply(met, search)
                or not margin_kept(met, search)):
            continue
        # the accents' glare stands out as the general lighting (and the background
        # luminance it gives) is dimmed: UGR of the whole at this level within the limit
        if glare is not None:
            if ugr_at(glare, f) > cap + 1e-9:
                continue
            # the parts add up but for the patches each part's luminaires cover (a few
            # hundredths of UGR): the whole at this level confirms, a bounded number of
            # times
            if exact_left <= 0:
                return
            exact_left -= 1
            whole = search.luminaires(_dimmed(cand, f)) + accents
            u = room_ugr(model, droom, whole)
            if u is not None and u > cap + 1e-9:
                continue
        # met spots stay met with a margin (the exact model is not the verification)
        if all(within(f * sp.base_mean + sp.achieved_mean - sp.base_mean, sp.goal.target_mean,
                      REDIM_SPOT_MARGIN * SPOT_TOLERANCE)
               for sp in spots if sp.ok):
            break
    else:
        return
    if f >= 1.0 - 1e-9:
        return
    rd.candidate = _dimmed(cand, f, met)
    rd.luminaires = search.luminaires(rd.candidate) + accents
    rd.metrics = met
    for sp in rd.spots:
        sp.achieved_mean += (f - 1.0) * sp.base_mean
        sp.base_mean *= f
    x = 100 * rd.general_outputs()
    level = (f"{x.min():.0f} %" if round(x.min()) == round(x.max())
             else f"{x.min():.0f} to {x.max():.0f} % (each luminaire by the same factor)")
    rd.notes.append(f"general lighting dimmed to {level} with the accents' light on the"
                    " work plane")


def _light_goals(scene, rd, model, droom, rs, entries, photometry, req, search=None):
    """Painted spots as requirements (accent luminaires where the general lighting leaves
    them too dark), other surface targets reported as goals; the exact figures of the
    whole installation replace those of the work-plane layout."""
    goals = find_goals(scene, rd.room)
    if not goals:
        return
    shade = _shade_points(scene, rd.room)
    aimable = [e for e in entries if e.aimable]
    if aimable:               # painted spots lit by aimed spots (accents.py)
        accents, rd.spots = light_spots_aimed(scene, model, droom, rs, aimable, photometry,
                                              rd.luminaires, goals,
                                              droom.floor_z + req.height_m,
                                              shade=shade if len(shade[0]) else None,
                                              shade_limit=rs.shade_limit_lux)
    else:
        accents, rd.spots = light_spots(model, droom, rs, entries, photometry, rd.luminaires,
                                        goals, droom.floor_z + req.height_m,
                                        shade=shade if len(shade[0]) else None,
                                        shade_limit=rs.shade_limit_lux)
    if accents:
        general = rd.luminaires
        rd.luminaires = rd.luminaires + accents
        rd.accent_watts = sum(s.accent_watts for s in rd.spots)
        # one exact solve per part (light adds up): the whole and every dimming level;
        # each with the whole installation's openings in place (what they cover reflects
        # and is left out of the surface grids as in the whole's solve)
        parts = (model.exact(general, covering=rd.luminaires),
                 model.exact(accents, covering=rd.luminaires))
        (G, Gd), (A, Ad) = parts
        rd.metrics = Metrics.of(G + A, Gd + Ad, model.layout)
        if search is not None:
            _redim_with_accents(rd, model, droom, search, parts, accents, req, rs)
    for sp in rd.spots:
        g = sp.goal
        if hasattr(sp, "describe"):          # aimed accents say their shape too
            rd.notes.append(sp.describe())
        elif g.kind == "spot":
            how = ("" if sp.accent is None else
                   f" with an accent {sp.accent.extra.get('type')} at"
                   f" {100 * sp.accent_watts / max(_entry_watts(entries, sp.accent), 1e-9):.0f} %")
            rd.notes.append(f"{g.label()}: {sp.achieved_mean:.0f} lx for"
                            f" {g.target_mean:.0f} lx (+/- {SPOT_TOLERANCE:.0%}):"
                            f" {'met' if sp.ok else 'NOT met'}{how}")
            if sp.note and not sp.ok:
                rd.notes.append(sp.note)
        else:
            rd.notes.append(f"{g.label()} ({g.n_vertices} target points, {g.area_m2:.1f} m2):"
                            f" {sp.achieved_mean:.0f} lx for {g.target_mean:.0f} lx on"
                            " average (a goal to approach, not judged)")


def _with_surroundings(rs, droom, req, surfaces, rd):
    """The room spec with its immediate surroundings' requirement (EN 12464-1:2021 Table 3)
    where the task area has a band around it; its grid joins ``surfaces`` (evaluated and
    searched like the walls)."""
    from dataclasses import replace
    from invrad_wb.core.design.cylindrical import (SURROUNDINGS_SOURCE, SURROUNDINGS_U0,
                                                   surroundings_grid, surroundings_lux)
    from invrad_wb.core.design.spec import SurfaceRequirement
    band = surroundings_grid(droom, req.height_m, req.margin_m)
    if band is None:
        rd.notes.append("immediate surroundings: the task area has no border zone around"
                        " it (margin 0): not computed")
        return rs
    surfaces["surroundings"] = band
    q = SurfaceRequirement(surroundings_lux(req.lux), SURROUNDINGS_U0, SURROUNDINGS_SOURCE)
    return replace(rs, surfaces={**rs.surfaces, "surroundings": q})


def _cylindrical_grid(model, droom, req, rs, rd, points=None):
    """The room's :class:`~.cylindrical.CylindricalGrid` where it asks for Ez, or None:
    on the task area's cells at the requirement's height (explicit task areas: their
    ``points`` lifted)."""
    if rs.cylindrical is None:
        return None
    from invrad_wb.core.design.cylindrical import CylindricalGrid
    from invrad_wb.errors import SceneError
    c = rs.cylindrical
    if getattr(rd.requirement, "task_areas", ()):
        return CylindricalGrid(model, np.c_[points[:, :2], np.full(len(points),
                                            droom.floor_z + c["height_m"])], c)
    try:
        pts, _ = droom.grid(c["height_m"], req.margin_m)
    except SceneError as e:
        rd.notes.append(f"cylindrical illuminance Ez not computed: {e}")
        return None
    return CylindricalGrid(model, pts, c)


def _entry_watts(entries, lum):
    return next((e.watts for e in entries if e.name == lum.extra.get("type")), 0.0)


def _reflectances(scene, room):
    """Area-weighted mean reflectance of the room's floor, walls and ceiling."""
    sel = (scene.face_room == room) & ~scene.face_virtual
    nz = scene.face_normals[:, 2]
    out = {}
    for part, m in (("ceiling", nz < -0.3), ("walls", np.abs(nz) <= 0.3),
                    ("floor", nz > 0.3)):
        s = sel & m
        if s.any():
            a = scene.face_areas[s]
            out[part] = round(float(np.sum(a * scene.face_reflectance[s]) / a.sum()), 3)
    return out


def design(scene, spec, room_names=None, backend="auto", progress=None, workers=1, dask=None,
           **kwargs):
    """Design every room of ``scene`` that has a requirement in ``spec``.

    Parameters
    ----------
    scene : Scene
    spec : DesignSpec
    room_names : dict room id -> name, or sequence by id, optional (spec keys may use them)
    backend : {'auto', 'opencl', 'numpy'}
    progress : callable(fraction, message) -> bool, optional; returning False cancels
    workers : int or 'auto'; rooms on this many local processes (same result as 1)
    dask : None, 'local' or a Dask scheduler address: rooms on a Dask cluster
    kwargs : passed to :func:`design_room` (mixed, dimming, fractions, photometry)

    Returns
    -------
    DesignResult
    """
    names = _room_names(scene, room_names)
    check_rooms(spec, names)
    check_task_areas(scene, spec, names)
    t0 = time.perf_counter()
    single = len(scene.rooms) <= 1
    labels = [name or f"room {room}" for room, name in names.items()]
    # each room's own faces only: a worker gets (and keeps) no more than its room
    tasks = [lambda room=room, name=name: (scene if single else scene.room_subset(room),
                                           spec, room, name, backend, kwargs)
             for room, name in names.items()]

    def report(i, n):
        def tell(frac, msg):
            if progress is not None and progress((i + frac) / n, msg) is False:
                raise Cancelled("design cancelled")
        return tell

    rooms = map_rooms(_design_task, tasks, labels, workers=workers, dask=dask,
                      progress=progress, report=report)
    result = DesignResult(rooms, spec, {"total": time.perf_counter() - t0})
    result.name_groups()
    return result


def _design_task(scene, spec, room, name, backend, kwargs, report=None):
    """One room on any worker (:func:`~invrad_wb.core.accel.workers.map_rooms`)."""
    if report is not None:
        report(0.0, f"{name or f'room {room}'}: design")
    return design_room(scene, spec, room, name, backend=backend, **kwargs)

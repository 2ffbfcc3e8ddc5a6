"""The headless pipeline over a whole building: targets -> locate -> fixtures -> report.

:func:`run` takes a FreeCAD document and, for every room with lighting targets (or the
rooms asked for):

1. meshes the room's boundary surfaces (metres, inward normals, per-surface reflectance)
   and evaluates its targets into lux per vertex (:mod:`invrad_wb.core.model.targets`); the
   work plane joins as virtual faces (transparent, non-reflecting, never a mounting
   plane: ``Scene(face_virtual=...)``);
2. builds ONE :class:`~invrad_wb.core.model.scene.Scene` of the building with a room id per
   room, and lets the core's ``locate`` find the luminaires room by room;
   rooms that meet with no wall between them (Küche, Wohnen and Flur of FZK-Haus: open
   borders, :func:`invrad_wb.app.rooms.open_borders`) are located as ONE lighting zone,
   on a copy of the scene with one room id per zone whose shared faces are virtual
   (transparent, non-reflecting, no targets, no mounting); each luminaire of a zone then
   goes to the room that contains it (:func:`assign_rooms`), so fixtures, summaries and
   the report stay per room, and a zone is never lit twice along its inner borders;
3. verifies them with a forward render (with interreflection by default; a zone's
   luminaires light all of the zone);
4. writes a report (:func:`invrad_wb.core.output.report.build_report`, plus ``summary.json``);
5. inserts the luminaires as light fixtures, as one undoable transaction.

Nothing in the document changes before step 5, and step 5 is all-or-nothing: a failed or
cancelled run (``progress`` returning False raises :class:`~invrad_wb.errors.Cancelled`)
leaves the document exactly as it was.

GUI commands call :func:`run` (or :func:`prepare` to preview meshes and targets).
"""
from collections import Counter
from dataclasses import dataclass, field, replace
import os
import time

import numpy as np

from invrad_wb.core.model import targets as CT
from invrad_wb.errors import Cancelled, SceneError
from invrad_wb.app import settings as S
from invrad_wb.app.document import describe
from invrad_wb.app.fixtures import fixture_label
from invrad_wb.app.rooms import (containing_room, find_spaces, get_space, lighting_zones,
                                  mesh_room, open_borders, room_name, room_shape)
from invrad_wb.app.targets import has_targets, room_specs


@dataclass
class PipelineSettings:
    """Options of a pipeline run (SI units).

    Attributes
    ----------
    flux_lm : luminous flux of one luminaire (lm), > 0; None: each luminaire's flux is
        fitted too (locate without a flux)
    resolution_m : longest triangle edge of the room meshes (m)
    interreflection : verify with interreflected light (radiosity)
    locate : LocateSettings, dict or None (core defaults)
    backend : 'auto', 'opencl' or 'numpy'
    replace : remove the fixtures of a previous invrad run in the processed rooms
    rooms : names, labels or GlobalIds of the rooms to process (None: rooms with targets)
    report_dir : folder for the report (None: no report)
    base_dir : folder that relative image paths of texture targets are relative to
    insert : insert the fixtures into the document (False: only compute and report)
    design : DesignSpec or None: design from requirements and a catalogue (least watts)
        instead of locating luminaires of ``flux_lm`` (which is then ignored)
    workers : rooms on this many worker processes (int or 'auto'; 1: in this process);
        the result is the same
    zones : locate rooms joined by open borders (no wall between them) as one lighting
        zone (default; not for a design, whose requirements and grids are per room: it
        keeps every room closed). The zone starts from its rooms located one by one
        (:func:`zone_seeds`), so no fixture is mounted on an open border and the two
        sides do not each get a row along it. On FZK-Haus (Kueche 500, Wohnen 300, Flur
        100 lx), all rendered with the borders open: rooms located alone 17 fixtures,
        579 / 476 / 276 lx, U0 0.64 / 0.48 / 0.33 (each room lights its side of the
        border as if it were a wall); the zone from its votes alone 13 wall lights,
        467 / 295 / 119 lx, U0 0.31 / 0.35 / 0.50; the seeded zone 11 fixtures (8 on
        the ceiling), 458 / 299 / 122 lx, U0 0.42 / 0.47 / 0.45. False: every room on
        its own, its open borders taken as walls (the earlier behaviour)
    requirements : rooms whose targets are requirements (a work-plane level, uniform
        surfaces: :mod:`invrad_wb.core.design.requirements`) get a regular layout of the
        luminaire that meets the level with the EN 12464-1 uniformity (default, when the
        flux is given); as in a design, rooms with a work-plane target keep their open
        borders as walls (no zone joins them). False: every room's targets fitted point
        by point (the earlier behaviour). FZK-Haus with ``examples/fzk_targets.json``
        (2000 lm): point by point 41 fixtures, 30 of them wall lights, U0 0.31-0.57, no
        room within its targets; as requirements 30 ceiling fixtures in regular rows,
        every room within -10/+30 % of its level and the EN 12464-1 uniformity for it
        (figures in the README)
    """
    flux_lm: float
    resolution_m: float = S.RESOLUTION_M
    interreflection: bool = True
    locate: object = None
    backend: str = "auto"
    replace: bool = True
    rooms: list = None
    report_dir: str = None
    base_dir: str = None
    insert: bool = True
    design: object = None
    workers: object = 1
    zones: bool = True
    requirements: bool = True


@dataclass
class RoomPlan:
    """One room of the building scene."""
    room_id: int
    space: object
    mesh: object
    targets: list
    work_plane: object
    faces: slice = None          # its faces in the building scene (before vertex split)
    n_work_plane: int = 0
    zone: int = None             # room id of its lighting zone in ``zone_scene``
    n_open: int = 0              # its triangles on open borders (virtual)


@dataclass
class BuildingScene:
    """The building's scene, one room id per room (``RoomPlan.room_id``), and the same
    scene (same vertices) with one room id per lighting zone (``RoomPlan.zone``) where
    open borders join rooms (``zone_scene``; None when every room is its own zone)."""
    scene: object
    rooms: list
    seconds: float = 0.0
    zone_scene: object = None
    borders: list = field(default_factory=list)

    @property
    def room_names(self):
        return [room_name(r.space) for r in self.rooms]

    @property
    def locate_scene(self):
        """The scene that locate and the forward render work on (room ids: zones)."""
        return self.zone_scene if self.zone_scene is not None else self.scene

    @property
    def zone_names(self):
        """``{zone id: 'Küche + Wohnen'}`` (the names of its rooms)."""
        out = {}
        for p in self.rooms:
            z = p.room_id if p.zone is None else p.zone
            out[z] = f"{out[z]} + {room_name(p.space)}" if z in out else room_name(p.space)
        return out

    def to_zones(self, luminaires):
        """Copies of luminaires of rooms (``room``: a room id) with their zone's id, for
        the forward render on :attr:`locate_scene`."""
        if self.zone_scene is None:
            return list(luminaires)
        zone = {p.room_id: p.zone for p in self.rooms}
        return [replace(l, room=zone.get(l.room, l.room), extra=dict(l.extra))
                for l in luminaires]


@dataclass
class PipelineResult:
    """What a run found and did."""
    building: BuildingScene
    luminaires: list
    fixtures: list
    target: np.ndarray
    achieved: np.ndarray
    locate_result: object = None
    report: object = None
    summary: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)


def check_flux(flux_lm):
    """The flux of one luminaire as a positive float, lm (else SettingsError)."""
    from invrad_wb.core.inverse.locate import check_flux as core_check
    return core_check(flux_lm)


def _progress(progress, lo, hi):
    """A sub-range [lo, hi] of a progress callback; cancelling raises Cancelled."""
    def report(frac, msg):
        if progress is not None:
            if progress(lo + (hi - lo) * min(max(float(frac), 0.0), 1.0), msg) is False:
                raise Cancelled(f"cancelled: {msg}")
        return True
    return report


def select_rooms(doc, rooms=None):
    """The Spaces to process: those named, or all Spaces that have targets."""
    spaces = find_spaces(doc)
    if not spaces:
        raise SceneError("the document has no rooms (Arch Spaces); make Spaces from walls"
                         " and slabs, or import an IFC file with IfcSpaces", doc.Label)
    if rooms:
        chosen = []
        for key in rooms:
            sp = key if hasattr(key, "TypeId") else get_space(doc, key)
            if sp not in chosen:
                chosen.append(sp)
        for sp in chosen:
            if not has_targets(sp):
                raise SceneError(f"room {describe(sp)} has no lighting targets", doc.Label)
        return chosen
    chosen = [sp for sp in spaces if has_targets(sp)]
    if not chosen:
        raise SceneError(f"none of the {len(spaces)} rooms has lighting targets (uniform,"
                         " spot, texture, shade or a work-plane illuminance)", doc.Label)
    return chosen


def prepare(doc, settings, progress=None):
    """Mesh the rooms and evaluate their targets into one building Scene (no doc change).

    Returns
    -------
    BuildingScene

    Raises
    ------
    SceneError, SettingsError
        No rooms, an open room, a target on a missing face, a bad lux value... naming the
        object at fault.
    """
    from invrad_wb.core.model.scene import Scene
    t0 = time.perf_counter()
    report = _progress(progress, 0.0, 1.0)
    spaces = select_rooms(doc, settings.rooms)
    shapes = [room_shape(sp) for sp in spaces]
    borders, zones = [], np.arange(len(spaces))
    if getattr(settings, "zones", True) and settings.design is None and len(spaces) > 1:
        report(0.0, "open borders between rooms")
        borders = open_borders(spaces, doc, shapes=shapes)
        if getattr(settings, "requirements", True) and settings.flux_lm is not None:
            # a room whose target is a work-plane level is laid out as Design does, its
            # open borders taken as walls (a design's requirements and grids are per room)
            from invrad_wb.app.targets import work_plane_target
            level = {k for k, sp in enumerate(spaces) if work_plane_target(sp) is not None}
            borders = [b for b in borders if b.a not in level and b.b not in level]
        zones = lighting_zones(len(spaces), borders)
    # slab openings over the rooms and stairs in them: where no luminaire may be mounted
    from invrad_wb.app.roomzones import no_mount_zones
    from invrad_wb.core.model.scene import NoMountZone
    no_mount = [NoMountZone(k, poly, words, pendants)
                for k, zones_k in enumerate(no_mount_zones(spaces, shapes, doc))
                for poly, words, pendants in zones_k]
    open_regions = [{} for _ in spaces]
    for b in borders:
        open_regions[b.a].setdefault(b.face_a, []).append(b.region_a)
        open_regions[b.b].setdefault(b.face_b, []).append(b.region_b)
    verts, faces, lux, room, rho, virtual = [], [], [], [], [], []
    plans = []
    nv = nf = 0
    for k, space in enumerate(spaces):
        report(k / len(spaces), f"room {room_name(space)}: mesh and targets")
        n_faces = len(shapes[k].Faces)
        specs, reflectance, wp = room_specs(space, n_faces, base_dir=settings.base_dir)
        mesh = mesh_room(space, settings.resolution_m, reflectance,
                         open_regions=open_regions[k])
        vl = CT.evaluate(mesh.vertices, mesh.triangles, mesh.triangle_face, specs,
                         source=space.Label, label=mesh.face_label,
                         base_dir=settings.base_dir)
        plan = RoomPlan(k, space, mesh, specs, wp, zone=int(zones[k]),
                        n_open=int(mesh.triangle_open.sum()))
        opened = mesh.triangle_open
        room_rho = mesh.triangle_reflectance
        if opened.any():                # an open border: no target, no reflection
            vl = np.asarray(vl, dtype=np.float64).copy()
            vl[np.unique(mesh.triangles[opened])] = np.nan
            room_rho = np.where(opened, 0.0, room_rho)
        parts = [(mesh.vertices, mesh.triangles, vl, room_rho, opened)]
        if wp is not None:
            wv, wt, wl = CT.work_plane(mesh.vertices, mesh.triangles, mesh.floor_triangles,
                                       wp, source=space.Label, surface=mesh.coarse)
            parts.append((wv, wt, wl, np.zeros(len(wt)), True))
            plan.n_work_plane = len(wt)
        start = nf
        for v, t, l, r, virt in parts:
            verts.append(v)
            faces.append(t + nv)
            lux.append(l)
            room.append(np.full(len(t), k))
            rho.append(r)
            virtual.append(np.zeros(len(t), dtype=bool) | virt)
            nv += len(v)
            nf += len(t)
        plan.faces = slice(start, nf)
        if not np.isfinite(np.concatenate([p[2] for p in parts])).any():
            raise SceneError(f"room {describe(space)}: its targets give no illuminance"
                             " anywhere (all 'no target')", space.Label)
        plans.append(plan)
    scene = Scene(np.concatenate(verts), np.concatenate(faces),
                  vertex_lux=np.concatenate(lux), face_room=np.concatenate(room),
                  face_reflectance=np.concatenate(rho),
                  face_virtual=np.concatenate(virtual), source=doc.Label,
                  no_mount=no_mount)
    zone_scene = None
    if len(np.unique(zones)) < len(spaces):
        # the same (split) vertices, so that per-vertex lux of one is that of the other
        zone_scene = Scene(scene.vertices, scene.faces, vertex_lux=scene.vertex_lux,
                           face_room=zones[scene.face_room],
                           face_reflectance=scene.face_reflectance,
                           face_virtual=scene.face_virtual, source=doc.Label,
                           check_winding=False, _split=False)
        zone_scene.vertex_source = scene.vertex_source.copy()
    report(1.0, "scene ready")
    return BuildingScene(scene, plans, time.perf_counter() - t0, zone_scene=zone_scene,
                         borders=borders)


def _room_stats(scene, target, achieved, plans):
    out = []
    vr = np.full(len(scene.vertices), -1)
    vr[scene.faces.reshape(-1)] = np.repeat(scene.face_room, 3)
    vvirt = np.zeros(len(scene.vertices), bool)
    vvirt[scene.faces[scene.face_virtual].reshape(-1)] = True
    for p in plans:
        sel = vr == p.room_id
        d = {"room": room_name(p.space), "space": p.space.Name,
             "triangles": int(len(p.mesh.triangles)), "work_plane_triangles": p.n_work_plane}
        for name, mask in (("surfaces", sel & ~vvirt), ("work_plane", sel & vvirt)):
            t = target[mask]
            a = achieved[mask]
            lit = np.isfinite(t) & (t > 0)
            dark = np.isfinite(t) & (t == 0)
            if lit.any():
                rel = (a[lit] - t[lit]) / t[lit]
                d[name] = {"targets": int(lit.sum()), "mean_target_lux": float(t[lit].mean()),
                           "mean_achieved_lux": float(a[lit].mean()),
                           "rms_relative_error": float(np.sqrt(np.mean(rel ** 2))),
                           "median_relative_error": float(np.median(np.abs(rel))),
                           "min_achieved_lux": float(a[lit].min())}
            if dark.any():
                d.setdefault(name, {})["shade_max_lux"] = float(a[dark].max())
        out.append(d)
    return out


def run(doc, settings, progress=None, locate=None, building=None):
    """The whole pipeline (see the module docstring).

    Parameters
    ----------
    doc : FreeCAD document
    settings : PipelineSettings
    progress : callable(fraction, message) -> bool, optional
        Return False to cancel: raises Cancelled and leaves the document unchanged.
    locate : callable, optional
        ``locate(scene, flux_lm=..., settings=..., progress=..., backend=...)`` returning an
        object with ``.luminaires``; default :func:`invrad_wb.core.inverse.locate.locate`.
    building : BuildingScene, optional
        The result of :func:`prepare` for these settings, when the caller has made it
        already (the GUI meshes the rooms in the main thread and runs the rest, with
        ``insert=False``, in a worker thread).

    Returns
    -------
    PipelineResult
    """
    flux = None
    if settings.design is None and settings.flux_lm is not None:
        flux = check_flux(settings.flux_lm)
    timings = {}
    t0 = time.perf_counter()
    if building is None:
        building = prepare(doc, settings, _progress(progress, 0.0, 0.1))
    timings["prepare"] = building.seconds
    scene = building.scene
    t = time.perf_counter()
    result = _find_luminaires(building, settings, flux, _progress(progress, 0.1, 0.75),
                              locate)
    timings["locate" if settings.design is None else "design"] = time.perf_counter() - t
    lums = list(result.luminaires)
    if settings.design is None:
        lums = assign_rooms(building, lums) + list(getattr(result, "fixed_luminaires", []))
    per_room = by_room(building, lums)
    step = _progress(progress, 0.75, 0.9)
    rooms_done = [room_name(p.space) for p in building.rooms]
    where = (f"{rooms_done[0]}: " if len(rooms_done) == 1
             else f"{len(rooms_done)} rooms: ")
    step(0.0, f"{where}verify {len(lums)} luminaire(s)")
    t = time.perf_counter()
    from invrad_wb.core.forward.render import render
    achieved = render(building.locate_scene, building.to_zones(lums),
                      interreflection=settings.interreflection, backend=settings.backend,
                      progress=lambda frac, msg: step(frac, f"{where}verify {len(lums)}"
                                                            f" luminaire(s): {msg}"))
    timings["verify"] = time.perf_counter() - t
    target = scene.vertex_lux.copy() if scene.vertex_lux is not None else scene.vertex_targets()
    summary = _summary(doc, flux, settings, building, target, achieved, per_room)
    if settings.design is None:
        summary["verdicts"] = room_verdicts(building, target, achieved,
                                            getattr(result, "room_targets", None),
                                            getattr(result, "requirements", None), flux)
        for d, v in zip(summary["rooms"], summary["verdicts"]):
            d["verdict"] = v
    if settings.design is not None:
        from invrad_wb.app.design import design_summary
        summary["design"] = design_summary(result)
    report_out = None
    if settings.report_dir:
        step = _progress(progress, 0.9, 0.97)
        step(0.0, "report")
        t = time.perf_counter()
        if settings.design is not None:     # the client's design report
            report_out = result.write_report(settings.report_dir,
                                             title=f"Lighting design: {doc.Label}",
                                             project=doc.Label)
            summary["report"] = report_out
        else:
            report_out = write_report(settings.report_dir, building, target, achieved,
                                      lums, summary)
        timings["report"] = time.perf_counter() - t
    _progress(progress, 0.97, 1.0)(0.0, "insert fixtures")
    fixtures = []
    if settings.insert:
        from invrad_wb.app.fixtures import insert_fixtures
        t = time.perf_counter()
        from invrad_wb.app.ifcexport import requirements_of_run
        name = f"invrad: {len(lums)} luminaire(s)"
        # fixtures and IFC requirements: one undo step of the document's backend
        fixtures = insert_fixtures(doc, [(p.space, per_room[p.room_id])
                                         for p in building.rooms],
                                   replace=settings.replace, name=name,
                                   requirements=requirements_of_run(building, summary))
        timings["insert"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    summary["timings"] = timings
    if settings.report_dir:
        _write_json(os.path.join(settings.report_dir, "summary.json"), summary)
    if progress is not None:
        progress(1.0, f"{len(lums)} luminaire(s) in {len(building.rooms)} room(s)")
    return PipelineResult(building, lums, [f.Name for f in fixtures], target, achieved,
                          locate_result=result, report=report_out, summary=summary,
                          timings=timings)


def _find_luminaires(building, settings, flux, progress, locate=None):
    """Design from requirements (``settings.design``) or locate luminaires of ``flux``;
    the core's result (with ``.luminaires``).

    Rooms whose targets are requirements (a work-plane level: :mod:`invrad_wb.core.design.
    requirements`) get a regular layout of the luminaire instead of a point-by-point fit,
    when the flux is given (:func:`_locate_requirements`); the result's
    ``fixed_luminaires`` then hold their luminaires (room ids), ``room_targets`` what each
    room's targets are."""
    if settings.design is not None:
        from invrad_wb.core.design.design import design
        return design(building.scene, settings.design, room_names=building.room_names,
                      backend=settings.backend, progress=progress, workers=settings.workers)
    extra = {} if settings.workers in (1, None) else {"workers": settings.workers}
    if locate is None:
        from invrad_wb.core.inverse.locate import locate
        kinds = classify_targets(building) if getattr(settings, "requirements", True) else {}
        if flux is not None and any(k.requirement for k in kinds.values()):
            return _locate_requirements(building, settings, flux, progress, locate, kinds,
                                        extra)
        seeds = zone_seeds(building, settings, flux, _progress(progress, 0.0, 0.4), locate,
                           **extra)
        if seeds:
            extra["seeds"] = seeds
            progress = _progress(progress, 0.4, 1.0)
        result = locate(building.locate_scene, flux_lm=flux, settings=settings.locate,
                        progress=progress, backend=settings.backend,
                        room_names=building.zone_names, **extra)
        result.room_targets = kinds
        return result
    return locate(building.locate_scene, flux_lm=flux, settings=settings.locate,
                  progress=progress, backend=settings.backend,
                  room_names=building.zone_names, **extra)


def classify_targets(building):
    """``{room id: RoomTargets}``: what each room's targets are (requirement or exact)."""
    from invrad_wb.core.design.requirements import classify_rooms
    names = {p.room_id: room_name(p.space) for p in building.rooms}
    return classify_rooms(building.scene, [p.room_id for p in building.rooms], names)


def _locate_requirements(building, settings, flux, progress, locate, kinds, extra):
    """Requirement rooms laid out regularly (the design engine with the given luminaire),
    the other rooms located as before: lighting zones of exact rooms only as one zone
    (seeded), exact rooms that share a zone with a requirement room on their own.

    Returns the exact zones' LocateResult (zone ids; possibly of no room) with
    ``fixed_luminaires`` (room ids: the requirement rooms' and the lone exact rooms'),
    ``requirements`` (the core's RequirementsResult) and ``room_targets``."""
    from dataclasses import asdict
    from invrad_wb.core.design.requirements import design_requirements
    from invrad_wb.core.inverse.locate import LocateResult, LocateSettings
    names = {p.room_id: room_name(p.space) for p in building.rooms}
    zone_of = {p.room_id: (p.room_id if p.zone is None else p.zone) for p in building.rooms}
    mixed = {zone_of[r] for r, k in kinds.items() if k.requirement}
    alone = [r for r in zone_of if zone_of[r] in mixed and not kinds[r].requirement]
    zones = sorted({z for z in zone_of.values() if z not in mixed})
    req = design_requirements(building.scene, kinds, flux, backend=settings.backend,
                              room_names=names, progress=_progress(progress, 0.0, 0.5),
                              workers=settings.workers)
    fixed = list(req.luminaires)
    progress = _progress(progress, 0.5, 1.0)
    if alone:
        res = locate(building.scene, flux_lm=flux, settings=settings.locate,
                     progress=progress, backend=settings.backend, rooms=alone,
                     room_names=names, **extra)
        fixed += list(res.luminaires)
    if zones:
        seeds = zone_seeds(building, settings, flux, progress, locate, zones=zones, **extra)
        if seeds:
            extra = dict(extra, seeds=seeds)
        result = locate(building.locate_scene, flux_lm=flux, settings=settings.locate,
                        progress=progress, backend=settings.backend, rooms=zones,
                        room_names=building.zone_names, **extra)
    else:
        s = settings.locate
        s = LocateSettings.from_dict(s) if isinstance(s, dict) else (s or LocateSettings())
        result = LocateResult([], asdict(s.check()), {"total": 0.0}, flux, [],
                              settings.backend)
    result.fixed_luminaires = fixed
    result.requirements = req
    result.room_targets = kinds
    result.timings["requirements"] = round(req.seconds, 4)
    return result


def zone_seeds(building, settings, flux, progress, locate, zones=None, **extra):
    """``{zone id: [Luminaire, ...]}``: the rooms of every lighting zone of several rooms
    located one by one (their open borders transparent, nothing mounted there), as the
    zone's seed arrangement (``locate(..., seeds=)``); {} without such zones.

    Located as one zone from its votes alone, the Kueche/Wohnen/Flur zone of FZK-Haus
    took 13 wall lights (U0 0.31 / 0.35 / 0.50 for its rooms); the seeded zone keeps 8 ceiling lights of 11 (U0 0.42 / 0.47 / 0.45) at a lower
    cost (0.0106 vs 0.0114), with no doubled row along the open borders.
    """
    if building.zone_scene is None:
        return {}
    zone = {p.room_id: p.zone for p in building.rooms}
    size = Counter(zone.values())
    rooms = [r for r, z in zone.items() if size[z] > 1 and (zones is None or z in zones)]
    if not rooms:
        return {}
    names = {p.room_id: room_name(p.space) for p in building.rooms}
    alone = locate(building.scene, flux_lm=flux, settings=settings.locate,
                   progress=progress, backend=settings.backend, rooms=rooms,
                   room_names={r: f"{names[r]} (alone)" for r in rooms}, **extra)
    out = {}
    for lum in alone.luminaires:
        out.setdefault(zone[lum.room], []).append(lum)
    return out


def assign_rooms(building, luminaires):
    """Luminaires of lighting zones (``room``: a zone id of ``building.locate_scene``) ->
    copies with the room id of the room that contains each (else the nearest room of its
    zone); luminaires of one-room zones just take that room's id."""
    if building.zone_scene is None:
        return list(luminaires)
    members = {}
    for k, p in enumerate(building.rooms):
        members.setdefault(p.zone, []).append(k)
    shapes = {}
    out = []
    for lum in luminaires:
        ks = members.get(lum.room)
        if ks is None:
            raise SceneError(f"a luminaire belongs to unknown zone id {lum.room!r}")
        if len(ks) == 1:
            k = ks[0]
        else:
            for j in ks:
                if j not in shapes:
                    shapes[j] = room_shape(building.rooms[j].space)
            k = containing_room(lum.position, [shapes.get(j) for j in
                                               range(len(building.rooms))], candidates=ks)
        out.append(replace(lum, room=building.rooms[k].room_id, extra=dict(lum.extra)))
    return out


def by_room(building, luminaires):
    """``{room id: [Luminaire, ...]}`` for every room of ``building`` (empty lists too;
    SceneError for a luminaire of a room that is not there)."""
    out = {p.room_id: [] for p in building.rooms}
    for lum in luminaires:
        if lum.room not in out:
            raise SceneError(f"a luminaire belongs to unknown room id {lum.room!r}")
        out[lum.room].append(lum)
    return out


def _summary(doc, flux, settings, building, target, achieved, per_room):
    """The run's summary dict: settings, per-room statistics of target vs achieved
    illuminance (lux, per vertex of ``building.scene``) and the luminaires with their
    room and fixture names."""
    summary = {
        "document": doc.Label, "flux_lm": flux, "resolution_m": settings.resolution_m,
        "interreflection": bool(settings.interreflection),
        "rooms": _room_stats(building.scene, target, achieved, building.rooms),
        "luminaires": [],
    }
    for p in building.rooms:
        for i, lum in enumerate(per_room[p.room_id]):
            d = lum.to_dict()
            d["room_name"] = room_name(p.space)
            d["fixture"] = fixture_label(p.space, i, lum)
            summary["luminaires"].append(d)
    return summary


def room_verdicts(building, target, achieved, kinds=None, requirements=None, flux=None,
                  located=True):
    """Per room (in ``building.rooms`` order) which targets are met and why not.

    Requirement rooms: Em against the level (-10/+30 %) and U0 against EN 12464-1 for the
    level on the task area (:func:`invrad_wb.core.design.requirements.judge`); exact rooms:
    the fit quality over the lit targets (relative RMS, share within 20 %) and a one-line
    warning when it is poor. Returns a list of dicts with ``targets``, ``met``, ``words``
    and, where not met, ``why_not`` and ``advice``. ``located=False`` (Verify: the
    fixtures in the document, however they came there) leaves out what is said of how
    Locate treated the room.
    """
    from invrad_wb.core.design.requirements import verdict_summary
    from invrad_wb.core.output.fitquality import fit_quality, poor_fit_warning
    if kinds is None:
        kinds = classify_targets(building)
    scene = building.scene
    vr = np.full(len(scene.vertices), -1)
    vr[scene.faces.reshape(-1)] = np.repeat(scene.face_room, 3)
    designed = {} if requirements is None else requirements.rooms
    out = []
    for p in building.rooms:
        name = room_name(p.space)
        rt = kinds.get(p.room_id)
        if rt is not None and rt.requirement:
            d = verdict_summary(scene, p.room_id, rt, achieved, name, requirements,
                                "these targets are requirements: Design (a catalogue of"
                                " luminaires, dimming) finds the layout of least power that"
                                " meets them")
            rd = designed.get(p.room_id)
            if rd is None and flux is None and located:
                d.setdefault("why_not", []).append(
                    "no luminaire flux given: the targets were fitted point by point; give"
                    " the flux for a regular layout, or use Design")
            out.append(d)
            continue
        sel = vr == p.room_id
        fq = fit_quality(target[sel], achieved[sel])
        d = {"targets": "exact", **fq.to_dict(), "met": not fq.poor,
             "words": f"{name}: {fq.words()}"}
        if rt is not None:
            d["reason"] = rt.reason
        warn = poor_fit_warning(name, fq)
        if warn:
            d["warning"] = warn
        out.append(d)
    return out


def describe_rooms(summary):
    """Lines for a person, per located room: its luminaires, the mean achieved against the
    target lux, and its verdict (met or not, the layout, why not, the advice); the
    ``freecad`` command prints them, the GUI shows them after Locate. The note that glare
    is rated for point sources is said once, after the rooms (:func:`point_source_note`)."""
    lines, small = [], []
    for room in summary["rooms"]:
        n = sum(1 for l in summary["luminaires"] if l["room_name"] == room["room"])
        line = f"room {room['room']}: {n} luminaire(s)"
        level = room.get("verdict", {}).get("targets") == "requirement"
        for part in ("surfaces",) if level else ("work_plane", "surfaces"):
            # a level is judged on its task area's grid (the verdict below), not over
            # the whole work plane up to the walls
            st = room.get(part, {})
            if "mean_target_lux" in st:
                line += (f"; {part.replace('_', ' ')} {st['mean_achieved_lux']:.0f} lx for"
                         f" {st['mean_target_lux']:.0f} lx")
        lines.append(line)
        kinds = {}
        for lum in summary["luminaires"]:
            if lum["room_name"] == room["room"] and "flux_group" in lum:
                kinds.setdefault(lum["flux_group"], []).append(lum["flux_lm"])
        lines += [f"  {len(f)} of one kind, {f[0]:.0f} lm each (their fluxes fitted as one)"
                  for _g, f in sorted(kinds.items())]
        v = room.get("verdict")
        if v:
            lines.append(f"  {'met' if v['met'] else 'NOT met'}: {v['words']}")
            if v.get("layout"):
                lines.append(f"    {v['layout']} ({v.get('mounting', 'ceiling')})")
            lines += [f"    {note}" for note in v.get("notes", ())
                      if not collect_small_sources(note, small)]
            lines += [f"    {why}" for why in v.get("why_not", ())]
            if v.get("advice"):
                lines.append(f"    {v['advice']}")
            if v.get("warning"):
                lines.append(f"  {v['warning']}")
    if small:
        lines.append(point_source_note(small))
    return lines


def small_source_types(note):
    """The luminaire types named by a room's note that its UGR rates them as small (point)
    sources (the design's wording, one such note per room), or None for any other note."""
    head, sep, _ = note.partition(" give no luminous area")
    if not sep or not head.startswith("UGR: "):
        return None
    return [t.strip() for t in head[len("UGR: "):].split(",") if t.strip()]


def collect_small_sources(note, small):
    """Add a point-source note's luminaire types to ``small``; True if it was one."""
    types = small_source_types(note)
    if types is None:
        return False
    small += [t for t in types if t not in small]
    return True


def point_source_note(types):
    """Once for all rooms, in plain words: glare rated with the luminaires as points."""
    return (f"Glare (UGR) is rated for point sources ({', '.join(types)}: no luminous size"
            " given), which gives an upper bound")


def _write_json(path, data):
    from invrad_wb.core.io.atomic import atomic_write_text
    from invrad_wb.core.io.jsonout import dumps
    atomic_write_text(path, dumps(data))


def write_report(out_dir, building, target, achieved, luminaires, summary):
    """The core's HTML/CSV report if it is available, and ``summary.json`` always."""
    os.makedirs(out_dir, exist_ok=True)
    out = None
    try:
        from invrad_wb.core.output.report import build_report
    except ImportError as exc:
        summary["report"] = f"no HTML report: invrad_wb.core.output.report is not available ({exc})"
    else:
        verdicts = {p.room_id: v for p, v in zip(building.rooms,
                                                  summary.get("verdicts", ()))}
        out = build_report(building.scene, target, achieved, luminaires, out_dir,
                           room_names=building.room_names, verdicts=verdicts or None)
        summary["report"] = str(getattr(out, "html", out))
    _write_json(os.path.join(out_dir, "summary.json"), summary)
    return out

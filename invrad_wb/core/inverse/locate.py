"""Locate luminaires: the inverted-radiosity pipeline, room by room.

For each room (faces sharing a room id; votes from a room go only to that room's planes and
dummy planes):

1. Poisson-disk voting points with their target illuminance (:mod:`.sampling`).
2. Vote maps on every plane and on the dummy planes (:mod:`.votemaps`); occlusion is used
   where the room is not convex ('auto'), only with the faces that can occlude.
3. Votes (:mod:`.votes`, exact model by default, or the thesis' deformed ellipses).
   With interreflection, the ambient part of the light is estimated and taken off the
   targets before voting (an interreflected contribution makes points look nearer to a
   luminaire than they are).
4. Peaks: Laplace filter, non-maxima suppression, joint 0-255 scaling, threshold
   (:mod:`.peaks`).
5. Joint refinement of the peaks against the targets with all luminaires' light and the
   interreflected light predicted together (:mod:`.refine`); peaks that do not lower the
   cost are dropped.

``locate(scene, flux_lm=...)`` returns a :class:`LocateResult`; ``result.repeak(...)``
re-runs steps 4-5 with a new threshold/neighbourhood without voting again.

This module is the orchestration (rooms, in this process or on workers); the parts are
modules of one job each: :mod:`.locate_settings` (settings and their checks),
:mod:`.locate_placement` (where a luminaire may go), :mod:`.locate_problem` (a room's vote
function, refinement problem and flux ladder), :mod:`.locate_fit` (the search from the
peaks) and :mod:`.locate_result` (the result and its pickling).
"""
from dataclasses import asdict
import time

import numpy as np

from invrad_wb.errors import Cancelled, SceneError
from invrad_wb.core.accel.device import check_backend
from invrad_wb.core.accel.workers import map_rooms
from invrad_wb.core.inverse.sampling import voting_points, default_density
from invrad_wb.core.inverse.votemaps import build_canvas
from invrad_wb.core.inverse.locate_settings import _checked_seeds, _checked_settings, check_flux
from invrad_wb.core.inverse.locate_placement import (_exclude_furniture_zone, _occluders,
                                                     _visible_from_brightest)
from invrad_wb.core.inverse.locate_problem import (AIM_FREE_LADDER_STEP, _ambient_estimate,
                                                   _flux_ladder, _refine_problem,
                                                   _vote_function)
from invrad_wb.core.inverse.locate_fit import _postprocess
from invrad_wb.core.inverse.locate_result import LocateResult, RoomRun, _collect
# the pipeline's parts, each in its module; their names stay importable from here
from invrad_wb.core.inverse.locate_settings import (  # noqa: F401
    INDIRECT_MODES, MOUNT_CLEARANCE_M, VOTE_MODELS, WORK_PLANE_CLEARANCE_M, LocateSettings)
from invrad_wb.core.inverse.locate_placement import (  # noqa: F401
    _make_inside, occluding_faces, room_is_convex, work_plane_height)
from invrad_wb.core.inverse.locate_problem import (  # noqa: F401
    FLUX_LADDER_OCTAVES, FLUX_LADDER_STEP, FREE_FLUX_MIN_GAIN_TOTAL)
from invrad_wb.core.inverse.locate_fit import (  # noqa: F401
    NEAR_EXACT_FIT, SPREAD_TOLERANCE, SPREAD_TRIGGER, _closest_pair, _lumen_spacing, _RoomFit,
    fit_quality)


def locate(scene, flux_lm, settings=None, progress=None, backend="auto", rooms=None,
           photometry=None, room_names=None, workers=1, dask=None, seeds=None,
           **overrides):
    """Find luminaire positions that produce a scene's target illuminance.

    Parameters
    ----------
    scene : Scene
        With targets (per vertex, per face or texture).
    flux_lm : float or None
        Luminous flux of one luminaire (lm). None: unknown, possibly different per
        luminaire; votes are cast for a ladder of fluxes (:data:`FLUX_LADDER_STEP` apart,
        from the room's lumen-method need down) and each luminaire's flux is fitted with
        its position.
    settings : LocateSettings or dict, optional
    progress : callable(fraction, message) -> bool, optional
        Return False to cancel (raises :class:`Cancelled`).
    backend : 'auto', 'opencl' or 'numpy'
    rooms : iterable of int, optional
        Rooms to process (default: all).
    photometry : Photometry, optional
        The luminaires' intensity distribution: the exact votes use it (averaged over its
        C planes: a candidate's rotation is not known yet), the refinement and its
        interreflection model the full distribution. None: lambertian.
    room_names : dict room id -> name, optional
        Names for the progress messages (a FreeCAD Space's label) instead of "room <id>".
    workers : int or 'auto'
        Rooms run on this many local worker processes (1: in this process); the result
        is the same (:func:`~invrad_wb.core.accel.workers.map_rooms`).
    dask : None, 'local' or a Dask scheduler address
        Rooms run on a Dask cluster instead.
    seeds : dict room id -> list of Luminaire, optional
        An arrangement to start from as well (e.g. the rooms of a lighting zone located
        one by one): refined in the room, pruned and added to from the vote candidates,
        and kept if its cost is lower than the votes' answer (:meth:`_RoomFit.seeded`).
        Seeds that are not on a surface of the room (nor pendants) are dropped.
    **overrides :
        Individual settings, e.g. ``pixel_m=0.05``.

    Returns
    -------
    LocateResult
    """
    s = _checked_settings(settings, overrides)
    flux = None if flux_lm is None else check_flux(flux_lm)
    if not scene.has_targets:
        raise SceneError("the scene has no target illuminance (no 'lux' values)", scene.source)
    backend = check_backend(backend)
    room_ids = scene.rooms if rooms is None else np.asarray(list(rooms))
    missing = set(int(r) for r in room_ids) - set(int(r) for r in scene.rooms)
    if missing:
        raise SceneError(f"no faces with room id(s) {sorted(missing)}", scene.source)
    timings = {k: 0.0 for k in ("sampling", "maps", "votes", "postprocess", "radiosity")}
    t_start = time.time()
    runs = []

    def report(frac, msg):
        if progress is not None and progress(frac, msg) is False:
            raise Cancelled(f"cancelled: {msg}")

    names = room_names or {}
    labels = [names.get(int(r)) or f"room {int(r)}" for r in room_ids]
    single = len(scene.rooms) <= 1

    seeds = _checked_seeds(seeds)

    def task(room, label):
        return (scene if single else scene.room_subset(room), room, s, flux, backend,
                photometry, label, not single, seeds.get(room))

    tasks = [lambda r=int(r), lb=lb: task(r, lb) for r, lb in zip(room_ids, labels)]
    done = map_rooms(_room_task, tasks, labels, workers=workers, dask=dask,
                     progress=progress,
                     report=lambda i, n: (lambda f, msg: report((i + f) / n, msg)))
    for run, t in done:
        runs.append(run)
        for k, v in t.items():
            timings[k] += v
    report(1.0, "done")
    timings["total"] = time.time() - t_start
    result = LocateResult(luminaires=_collect(runs), settings=asdict(s),
                          timings={k: round(v, 4) for k, v in timings.items()}, flux_lm=flux,
                          rooms=runs, backend=backend)
    return result


def _room_task(sub, room, s, flux, backend, photometry, label, subset_scene=True,
               seeds=None, report=None):
    """One room on any worker: ``(RoomRun, seconds per stage)``. ``subset_scene``: ``sub``
    is the room's own copy (its caches may go), not the caller's scene; ``seeds``: the
    room's seed luminaires (see :func:`locate`)."""
    timings = {k: 0.0 for k in ("sampling", "maps", "votes", "postprocess", "radiosity")}
    run = _locate_room(sub, room, s, flux, backend, timings,
                       report or (lambda f, msg: None), photometry, label=label,
                       seeds=seeds)
    # memory bounded by the largest room, not the building: a room's refinement problem
    # and radiosity model (tens of MB) go once it is done (repeak rebuilds them)
    run.own_scene = subset_scene
    return run.detach(), timings


def _locate_room(sub, room, s, flux, backend, timings, report, photometry=None,
                 label=None, seeds=None):
    """Steps 1-5 of the module docstring for one room (``sub``: its faces only); returns
    its :class:`RoomRun`.

    ``label`` names the room in progress messages (default "room <id>"). ``timings``
    (seconds per stage) is added to; ``report(fraction of this room, message)``
    reports progress (and raises :class:`Cancelled`).
    """
    label = label or f"room {room}"
    report(0.0, f"{label}: voting points")
    t = time.time()
    density = s.votes_per_m2 or default_density(sub)
    pts = voting_points(sub, density=density, seed=s.seed)
    timings["sampling"] += time.time() - t
    if len(pts) == 0 or not np.any(pts.lux > 0):
        canvas = build_canvas(sub, room, s.pixel_m, dummy=False)
        return RoomRun(room=room, scene=sub, points=pts, canvas=canvas,
                       votes=np.zeros(canvas.size, np.float32), problem=None,
                       occluders=None, ambient_lux=0.0, flux=flux or 1.0,
                       free_flux=flux is None, label=label)
    lit = pts.lux > 0
    occ = _occluders(sub, s)
    # interreflection
    has_rho = bool(np.any(sub.face_reflectance[~sub.face_virtual] > 0))
    ambient = _ambient_estimate(sub, pts) if (s.indirect != "none" and has_rho) else 0.0
    report(0.1, f"{label}: vote maps")
    t = time.time()
    planes = None
    if not s.all_planes:
        planes = _visible_from_brightest(sub, pts.subset(lit), None)
    canvas = build_canvas(sub, room, pixel=s.pixel_m, dummy=s.dummy_planes,
                          dummy_spacing=s.dummy_spacing_m, dummy_count=s.dummy_count,
                          dummy_lowest=s.dummy_lowest_m, two_sided=s.two_sided_dummies,
                          planes=planes)
    _exclude_furniture_zone(sub, canvas)
    timings["maps"] += time.time() - t
    report(0.2, f"{label}: votes")
    free = flux is None
    ladder = {}
    if free:
        ladder = _flux_ladder(pts) if s.aim != "free" else _flux_ladder(
            pts, step=AIM_FREE_LADDER_STEP)
        flux = max(ladder)
    vote_fn = _vote_function(canvas, pts, ambient, occ, s, flux, backend, timings, photometry)
    if free:
        # votes as if 1/share of the light came from a luminaire of flux: one of f = share*flux
        ladder = {f: vote_fn(f / flux) for f in ladder}
        votes = max(ladder.values(), key=lambda v: float(np.max(v, initial=0.0)))
    else:
        votes = vote_fn(1)
    prob, indirect_model = _refine_problem(sub, pts, canvas, occ, s, flux, backend, has_rho,
                                           timings, photometry, at_vertices=free)
    prob.free_flux = free
    run = RoomRun(room=room, scene=sub, points=pts, canvas=canvas, votes=votes,
                  problem=prob, occluders=occ, ambient_lux=ambient,
                  indirect_model=indirect_model, vote_fn=vote_fn, flux=flux,
                  free_flux=free, ladder_votes=ladder,
                  remake=(s, backend, photometry, has_rho), label=label,
                  seeds=list(seeds or []))
    report(0.5, f"{label}: peaks and refinement")
    t = time.time()
    _postprocess(run, s, flux,
                 progress=lambda f: report(0.5 + 0.5 * f, f"{label}: refinement"))
    timings["postprocess"] += time.time() - t
    return run



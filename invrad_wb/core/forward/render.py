"""Forward solve: the illuminance that given luminaires produce on a scene's vertices.

``render(scene, luminaires)`` is what the CLI ``render`` command, the tests (scenes with a
known answer) and the verification report use: direct light with occlusion
(:mod:`invrad_wb.core.forward.direct`) plus, optionally, interreflected light from a radiosity solve
(:mod:`invrad_wb.core.forward.radiosity`).

Memory by room count: the radiosity model of a whole scene keeps every room's patch matrix
and vertex gather block (a floor of 256 rooms: gigabytes). :func:`radiosity_memory`
estimates it before anything is built; above half the memory budget the interreflections
are computed one room at a time (a model per room, dropped after it; rooms do not exchange
light in the model, so the result is the same) and only the largest room must fit.
"""
import gc
import math

import numpy as np

from invrad_wb import constants as C
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.accel.device import check_backend
from invrad_wb.core.forward.direct import direct_illuminance
from invrad_wb.errors import Cancelled

#: bytes per patch pair of a room's model: the float64 patch matrix, its visibility (bool)
#: and the float64 blocks its construction sums (measured: bench/bench_memory.py)
PATCH_PAIR_BYTES = 8 + 1 + 8
#: bytes per vertex and patch of the stored float32 vertex gather block
GATHER_BYTES = 4


def scene_bvh(scene):
    """The scene's occlusion BVH, built once per Scene object."""
    bvh = getattr(scene, "_bvh", None)
    if bvh is None:
        bvh = BVH(scene.triangles[scene.occluder_faces])
        scene._bvh = bvh
    return bvh


def radiosity_memory(scene, patch_size=None):
    """Estimated bytes of the radiosity model of ``scene``, before it is built.

    Per room: patches ``P`` = for each of its planes, area / edge^2 plus the cells its
    outline cuts (2 sqrt(area) / edge + 1), with the edge of
    :func:`~invrad_wb.core.forward.radiosity.default_patch_size`; bytes
    ``PATCH_PAIR_BYTES P^2`` plus the vertex gather block ``GATHER_BYTES n P`` (``n`` the
    room's vertices; not stored above ``RADIOSITY_GATHER_MAX_MB``) plus the working chunks
    (``2 RADIOSITY_CL_CHUNK_MB``).

    Returns
    -------
    total : float, bytes of the whole scene's model (all rooms kept)
    rooms : dict room id -> (bytes, estimated patches, patch edge m)
    """
    from invrad_wb.core.forward.radiosity import default_patch_size
    areas = scene.face_areas
    plane_area, plane_room = {}, {}
    for pl in scene.planes:
        plane_area[pl.index] = float(areas[pl.faces].sum())
        plane_room[pl.index] = int(pl.room)
    order = np.argsort(scene.face_room, kind="stable")
    bounds = np.searchsorted(scene.face_room[order], scene.rooms)
    ends = np.r_[bounds[1:], len(order)]
    vertex_room_count = {}
    for r, a, b in zip(scene.rooms, bounds, ends):
        vertex_room_count[int(r)] = len(np.unique(scene.faces[order[a:b]]))
    chunk = 2 * (C.RADIOSITY_CL_CHUNK_MB << 20)
    total, rooms = 0.0, {}
    for r, a, b in zip(scene.rooms, bounds, ends):
        r = int(r)
        faces = order[a:b]
        edge = float(patch_size) if patch_size is not None else default_patch_size(scene,
                                                                                   faces)
        p = sum(A / edge ** 2 + 2.0 * math.sqrt(A) / edge + 1.0
                for k, A in plane_area.items() if plane_room[k] == r)
        gather = GATHER_BYTES * vertex_room_count[r] * p
        if gather > C.RADIOSITY_GATHER_MAX_MB << 20:
            gather = 0.0          # recomputed at each use instead of stored
        nbytes = PATCH_PAIR_BYTES * p * p + gather
        rooms[r] = (nbytes + chunk, p, edge)
        total += nbytes
    return total + chunk, rooms


#: (emitter sample, receiving point) pairs above which a render is announced with its
#: size before it starts: seconds on a two-core CPU (PoCL) in a convex room, about ten
#: where every pair needs a shadow ray
LARGE_RENDER_RAYS = 2e7


def render_work(scene, luminaires, interreflection=True):
    """(pairs, points) of :func:`render`: every emitter sample towards every vertex
    and, with interreflections, every patch's sample point (the direct light's cost, which
    grows as luminaires x points)."""
    from invrad_wb.core.forward.direct import emitter_memory
    _, samples = emitter_memory(luminaires)
    points = len(scene.vertices)
    if interreflection:
        points += int(sum(p for _, p, _ in radiosity_memory(scene)[1].values()))
    return float(samples) * points, points


def work_note(scene, luminaires, interreflection=True):
    """One line announcing a large render (luminaires x points), or None for a small one."""
    rays, points = render_work(scene, luminaires, interreflection)
    if rays < LARGE_RENDER_RAYS:
        return None
    return (f"{len(luminaires)} luminaire(s) x {points} points: about {rays:.2g}"
            " (luminaire, point) pairs; this takes a while (fewer luminaires, a coarser"
            " mesh or an OpenCL GPU is faster)")


def render(scene, luminaires, interreflection=True, occlusion=True, backend="auto",
           patch_size=None, return_parts=False, progress=None):
    """Illuminance (lux) at each vertex of ``scene``.

    Parameters
    ----------
    scene : Scene
    luminaires : list of Luminaire
    interreflection : bool
        Add the interreflected light of a radiosity solve (per room).
    occlusion : bool
        Let the scene cast shadows.
    backend : {'auto', 'opencl', 'numpy'}
    patch_size : float, optional
        Radiosity patch edge in metres (default: chosen per room).
    return_parts : bool
        Also return the direct and indirect parts.
    progress : callable(fraction, message) -> bool, optional
        Told how far the render is, by luminaire pairs done (direct light at the
        vertices, then at the radiosity patches); return False to cancel (raises
        :class:`~invrad_wb.errors.Cancelled`).

    Returns
    -------
    (n,) float64 lux, or ``(total, direct, indirect)`` if ``return_parts``.

    Raises
    ------
    MemoryLimitError
        If one room's radiosity model alone would exceed the memory budget.
    """
    backend = check_backend(backend)
    bvh = scene_bvh(scene)
    luminaires = list(luminaires)
    split = 1.0
    if interreflection and progress is not None:
        # the direct light's share of the work: vertices against vertices and patches
        _, points = render_work(scene, luminaires, True)
        split = len(scene.vertices) / max(1, points)
    direct = _direct_by_room(scene, luminaires, bvh, occlusion, backend,
                             _stage(progress, 0.0, split,
                                    f"direct light of {len(luminaires)} luminaire(s)"))
    indirect = np.zeros_like(direct)
    if interreflection:
        indirect = indirect_light(scene, direct, backend=backend, patch_size=patch_size,
                                  occlusion=occlusion, luminaires=luminaires, bvh=bvh,
                                  progress=_stage(progress, split, 1.0, "interreflection"))
    if progress is not None and progress(1.0, "rendered") is False:
        raise Cancelled("cancelled: render")
    total = direct + indirect
    return (total, direct, indirect) if return_parts else total


def _stage(progress, lo, hi, msg):
    """``progress(fraction)`` for a part [lo, hi] of a render, saying ``msg`` (None
    without a progress callback); a False from the callback raises Cancelled."""
    if progress is None:
        return None

    def report(frac):
        if progress(lo + (hi - lo) * min(max(float(frac), 0.0), 1.0), msg) is False:
            raise Cancelled(f"cancelled: {msg}")
    return report


def _sub(progress, lo, hi):
    """A part [lo, hi] of a stage's ``progress(fraction)`` (None stays None)."""
    if progress is None:
        return None
    return lambda frac: progress(lo + (hi - lo) * frac)


def indirect_light(scene, vertex_direct, backend="auto", patch_size=None, occlusion=True,
                   by_room=None, luminaires=None, bvh=None, progress=None):
    """Interreflected illuminance at the scene's vertices for their direct light.

    Parameters
    ----------
    scene : Scene
    vertex_direct : (n,) float64, lux
    luminaires : list of Luminaire, optional
        The luminaires of ``vertex_direct``: each patch then gets its mean direct light
        from them (:meth:`RadiosityModel.patch_direct`: exact near a luminaire) instead of
        the mean of its vertices' values, which misses most of the light of a luminaire
        close to a surface (a downlight 0.1 m from two walls: 1132 of its 2000 lm).
    bvh : BVH, optional
        The scene's occluders for ``luminaires`` (with ``occlusion``).
    by_room : bool, optional
        One model per room, each dropped after its room (bounded memory), instead of the
        scene's cached model. Default: when the whole model's estimate exceeds half the
        memory budget (:func:`radiosity_memory`).
    progress : callable(fraction), optional
        Told the fraction done (the patches' direct light, room by room).

    Returns
    -------
    (n,) float64, lux
    """
    from invrad_wb.core.forward.radiosity import RadiosityModel
    from invrad_wb.core.model.memory import limit_bytes, require
    if by_room is None:
        if RadiosityModel.cached(scene, backend, patch_size, occlusion) is not None:
            by_room = False                       # built already: use it
        else:
            total, rooms = radiosity_memory(scene, patch_size)
            by_room = len(rooms) > 1 and total > limit_bytes() / 2
            r, (nbytes, p, edge) = max(rooms.items(), key=lambda kv: kv[1][0])
            require(nbytes if by_room else total,
                    f"the radiosity model of {'room ' + str(r) if by_room else 'the scene'}"
                    f" (about {p:.0f} patches of {edge:.2f} m"
                    f"{'' if by_room else f' in room {r}; {len(rooms)} room(s) in all'})",
                    "give a larger patch size, or no interreflections")
    if progress is not None:
        progress(0.0)
    if not by_room:
        model = RadiosityModel.for_scene(scene, backend=backend, patch_size=patch_size,
                                         occlusion=occlusion)
        return _indirect_at_vertices(model, vertex_direct, luminaires, bvh, occlusion,
                                     progress)
    vertex_direct = np.asarray(vertex_direct, dtype=np.float64)
    out = np.zeros_like(vertex_direct)
    # each room's faces as a scene of its own; its vertices carry their index in this one
    index = scene.with_vertex_lux(np.arange(len(scene.vertices), dtype=np.float64))
    for k, r in enumerate(scene.rooms):
        sub = index.face_subset(np.flatnonzero(scene.face_room == r))
        parent = sub.vertex_lux.astype(np.int64)
        model = RadiosityModel(sub, backend=backend, patch_size=patch_size,
                               occlusion=occlusion)
        out[parent] = _indirect_at_vertices(
            model, vertex_direct[parent], luminaires, bvh, occlusion,
            _sub(progress, k / len(scene.rooms), (k + 1) / len(scene.rooms)))
        del model, sub
        # a model and its gather operator refer to each other: without a collection here
        # each room's matrices stay until the cyclic collector runs (measured: +19 MB per
        # room, 64 rooms 976 MB; with it flat at 170 MB)
        gc.collect()
    return out


def _indirect_at_vertices(model, vertex_direct, luminaires, bvh, occlusion, progress=None):
    if luminaires is None:
        out = model.indirect_at_vertices(vertex_direct)
    else:
        out = model.vertex_gather()(model.solve(model.patch_direct(luminaires, bvh, occlusion,
                                                                   progress=progress)))
    if progress is not None:
        progress(1.0)
    return out


def _direct_by_room(scene, luminaires, bvh, occlusion, backend, progress=None):
    """Direct light at the scene's vertices; a luminaire with a room lights only the
    vertices of its room (as locate, design and the interreflection model see rooms).

    Rooms are closed, so walls keep each room's light in; but where two rooms touch
    without a wall between them (FZK-Haus: Kueche and Wohnen share an open border), the
    vertices on the shared border lie in the other room's boundary plane, no face stands
    between them and its luminaires, and they took its light: a saw-tooth strip of the
    neighbour's light along the border in plans and false colours. Vertices of no room or
    of several rooms, and luminaires without a room, keep the light of every luminaire.
    """
    lums = list(luminaires)
    vr = _vertex_rooms(scene)
    roomed = [lum.room for lum in lums if lum.room is not None]
    used = vr[vr >= 0] if vr is not None else np.zeros(0, dtype=np.int64)
    if (vr is None or not roomed or not len(used)
            or (np.all(vr == used[0]) and all(r == used[0] for r in roomed))):
        return direct_illuminance(scene.vertices, scene.vertex_normals, lums, bvh=bvh,
                                  occlusion=occlusion, backend=backend, progress=progress)
    out = np.zeros(len(scene.vertices))
    shared = [lum for lum in lums if lum.room is None]
    rest = np.flatnonzero(vr < 0)
    parts = [(rest, lums)] if len(rest) else []
    for r in np.unique(used):
        mine = [lum for lum in lums if lum.room is not None and int(lum.room) == r] + shared
        if mine:
            parts.append((np.flatnonzero(vr == r), mine))
    # progress by (luminaire, vertex) pairs, part after part
    work = np.cumsum([0] + [len(idx) * len(mine) for idx, mine in parts], dtype=np.float64)
    work /= max(work[-1], 1.0)
    for k, (idx, mine) in enumerate(parts):
        out[idx] = direct_illuminance(scene.vertices[idx], scene.vertex_normals[idx], mine,
                                      bvh=bvh, occlusion=occlusion, backend=backend,
                                      progress=_sub(progress, work[k], work[k + 1]))
    return out


def _vertex_rooms(scene):
    """(n,) int room of each vertex (-1: unused or used by faces of several rooms), or
    None when the scene has no rooms."""
    fr = getattr(scene, "face_room", None)
    if fr is None:
        return None
    fr = np.asarray(fr, dtype=np.int64)
    n = len(scene.vertices)
    lo = np.full(n, np.iinfo(np.int64).max)
    hi = np.full(n, np.iinfo(np.int64).min)
    corners = scene.faces.reshape(-1)
    np.minimum.at(lo, corners, np.repeat(fr, 3))
    np.maximum.at(hi, corners, np.repeat(fr, 3))
    return np.where((lo == hi), lo, -1)

"""Forward solve: the illuminance that given luminaires produce on a scene's vertices.

``render(scene, luminaires)`` is what the CLI ``render`` command, the tests (scenes with a
known answer) and the verification report use: direct light with occlusion
(:mod:`invrad_wb.core.forward.direct`) plus, optionally, interreflected light from a radiosity solve
(:mod:`invrad_wb.core.forward.radiosity`).
"""
import numpy as np

from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.accel.device import check_backend
from invrad_wb.core.forward.direct import direct_illuminance


def scene_bvh(scene):
    """The scene's occlusion BVH, built once per Scene object."""
    bvh = getattr(scene, "_bvh", None)
    if bvh is None:
        bvh = BVH(scene.triangles[scene.occluder_faces])
        scene._bvh = bvh
    return bvh


def render(scene, luminaires, interreflection=True, occlusion=True, backend="auto",
           patch_size=None, return_parts=False):
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

    Returns
    -------
    (n,) float64 lux, or ``(total, direct, indirect)`` if ``return_parts``.
    """
    backend = check_backend(backend)
    bvh = scene_bvh(scene)
    direct = _direct_by_room(scene, luminaires, bvh, occlusion, backend)
    indirect = np.zeros_like(direct)
    if interreflection:
        from invrad_wb.core.forward.radiosity import RadiosityModel
        model = RadiosityModel.for_scene(scene, backend=backend, patch_size=patch_size,
                                         occlusion=occlusion)
        indirect = model.indirect_at_vertices(direct)
    total = direct + indirect
    return (total, direct, indirect) if return_parts else total


def _direct_by_room(scene, luminaires, bvh, occlusion, backend):
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
                                  occlusion=occlusion, backend=backend)
    out = np.zeros(len(scene.vertices))
    shared = [lum for lum in lums if lum.room is None]
    rest = np.flatnonzero(vr < 0)
    if len(rest):
        out[rest] = direct_illuminance(scene.vertices[rest], scene.vertex_normals[rest],
                                       lums, bvh=bvh, occlusion=occlusion, backend=backend)
    for r in np.unique(used):
        idx = np.flatnonzero(vr == r)
        mine = [lum for lum in lums if lum.room is not None and int(lum.room) == r] + shared
        if mine:
            out[idx] = direct_illuminance(scene.vertices[idx], scene.vertex_normals[idx],
                                          mine, bvh=bvh, occlusion=occlusion,
                                          backend=backend)
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

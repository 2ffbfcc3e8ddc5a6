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
    direct = direct_illuminance(scene.vertices, scene.vertex_normals, luminaires, bvh=bvh,
                                occlusion=occlusion, backend=backend)
    indirect = np.zeros_like(direct)
    if interreflection:
        from invrad_wb.core.forward.radiosity import RadiosityModel
        model = RadiosityModel.for_scene(scene, backend=backend, patch_size=patch_size,
                                         occlusion=occlusion)
        indirect = model.indirect_at_vertices(direct)
    total = direct + indirect
    return (total, direct, indirect) if return_parts else total

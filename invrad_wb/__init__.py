"""invrad: inverse lighting design for FreeCAD (the "Inverted Radiosity" method).

The package is usable without FreeCAD: ``invrad_wb.core`` holds the scene model, the forward
solver, the votes and the refinement. FreeCAD-specific code lives in ``invrad_wb.app`` (the
document side) and ``invrad_wb.gui`` (commands), which the workbench loads.

Python API::

    from invrad_wb import read_scene, locate, render
    scene = read_scene("room.ply")
    result = locate(scene, flux_lm=3000)
"""
__version__ = "0.1.0"


def locate(scene, flux_lm, settings=None, **kwargs):
    """Find luminaire positions; see :func:`invrad_wb.core.inverse.locate.locate`."""
    from invrad_wb.core.inverse.locate import locate as _locate
    return _locate(scene, flux_lm, settings=settings, **kwargs)


def render(scene, luminaires, **kwargs):
    """Illuminance at the scene's vertices; see :func:`invrad_wb.core.forward.render.render`."""
    from invrad_wb.core.forward.render import render as _render
    return _render(scene, luminaires, **kwargs)


def read_scene(path, **kwargs):
    """Read a scene file; see :func:`invrad_wb.core.io.sceneio.read_scene`."""
    from invrad_wb.core.io.sceneio import read_scene as _read
    return _read(path, **kwargs)

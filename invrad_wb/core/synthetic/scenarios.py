"""Known-answer scenes: generated rooms lit by known luminaires (for tests and benchmarks).

Each scenario renders its luminaires with the forward solver and stores the result as the
scene's targets, so that locating them again has a known answer. ``match`` compares found
and true luminaires.
"""
import numpy as np

from invrad_wb.core.synthetic import generate as g
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.forward.render import render

#: name -> builder(reflectance) -> (scene without targets, luminaires)
_BUILDERS = {}
#: scenes whose luminaires differ in flux (for locate without a flux); name -> builder
_MIXED = {}


def _registrar(table):
    """A decorator factory that files a builder under its name in ``table``."""
    def register(name):
        def deco(fn):
            table[name] = fn
            return fn
        return deco
    return register


_scenario = _registrar(_BUILDERS)
_mixed = _registrar(_MIXED)


def _down(p, flux=3000.0, radius=0.0):
    return Luminaire(p, [0, 0, -1], flux, radius)


@_scenario("one_ceiling")
def _one(rho, cell):
    return g.box_room((6, 4, 3), cell=cell, reflectance=rho), [_down([2.3, 1.7, 3.0])]


@_scenario("two_ceiling")
def _two(rho, cell):
    return (g.box_room((6, 4, 3), cell=cell, reflectance=rho),
            [_down([2.0, 1.5, 3.0]), _down([4.2, 2.6, 3.0])])


@_scenario("wall_light")
def _wall(rho, cell):
    return (g.box_room((5, 4, 3), cell=cell, reflectance=rho),
            [Luminaire([0.0, 2.2, 2.2], [1, 0, 0], 3000.0)])


@_scenario("pendant")
def _pendant(rho, cell):
    return g.box_room((6, 4, 3.2), cell=cell, reflectance=rho), [_down([3.1, 2.2, 2.25])]


@_scenario("pillar")
def _pillar(rho, cell):
    return (g.pillar_room((6, 4, 3), pillar=((2.8, 1.8), (3.2, 2.2)), cell=cell,
                          reflectance=rho),
            [_down([1.5, 2.0, 3.0]), _down([4.5, 2.1, 3.0])])


@_scenario("l_room")
def _lroom(rho, cell):
    return (g.l_room((6, 5, 3), cut=(3, 2.5), cell=cell, reflectance=rho),
            [_down([1.5, 3.8, 3.0]), _down([4.5, 1.2, 3.0])])


@_scenario("sloped")
def _sloped(rho, cell):
    scene = g.sloped_room((6, 4), low=2.5, high=4.0, cell=cell, reflectance=rho)
    slope = 1.5 / 6
    n = np.array([slope, 0.0, -1.0])
    n /= np.linalg.norm(n)
    return scene, [Luminaire([4.0, 2.1, 2.5 + slope * 4.0], n, 3000.0)]


@_scenario("disk")
def _disk(rho, cell):
    return g.box_room((6, 4, 3), cell=cell, reflectance=rho), [_down([3.2, 1.9, 3.0],
                                                                     radius=0.3)]


@_scenario("four_rooms")
def _four(rho, cell):
    scene, origins = g.floor_of_rooms(((4, 4), (4, 4), (5, 4), (3, 4)), height=3.0,
                                      cell=cell, reflectance=rho)
    offsets = [(1.7, 2.2), (2.3, 1.6), (2.6, 2.4), (1.4, 1.9)]
    lums = []
    for room, (o, (dx, dy)) in enumerate(zip(origins, offsets)):
        L = _down([o[0] + dx, o[1] + dy, 3.0])
        L.room = room
        lums.append(L)
    return scene, lums


SCENARIOS = tuple(_BUILDERS)


@_mixed("three_fluxes")
def _three_fluxes(rho, cell):
    return (g.box_room((7, 5, 3), cell=cell, reflectance=rho),
            [_down([1.6, 1.4, 3.0], 1500.0), _down([4.0, 3.3, 3.0], 3000.0),
             _down([5.8, 1.5, 3.0], 4500.0)])


@_mixed("wall_and_ceiling")
def _wall_and_ceiling(rho, cell):
    return (g.box_room((5, 4, 3), cell=cell, reflectance=rho),
            [Luminaire([0.0, 2.2, 2.2], [1, 0, 0], 800.0), _down([3.2, 2.0, 3.0], 2500.0)])


@_mixed("two_rooms_two_fluxes")
def _two_rooms(rho, cell):
    scene, origins = g.floor_of_rooms(((4, 4), (5, 4)), height=3.0, cell=cell,
                                      reflectance=rho)
    lums = []
    for room, (o, spots) in enumerate(zip(origins, [[(1.2, 1.5, 1200.0), (2.9, 2.6, 1200.0)],
                                                    [(1.6, 2.1, 2000.0), (3.7, 1.8, 3500.0)]])):
        for dx, dy, f in spots:
            L = _down([o[0] + dx, o[1] + dy, 3.0], f)
            L.room = room
            lums.append(L)
    return scene, lums


MIXED_SCENARIOS = tuple(_MIXED)


def known_scene(name, reflectance=0.0, interreflection=None, cell=0.1, backend="auto"):
    """A scenario with targets rendered from its luminaires.

    Parameters
    ----------
    name : one of :data:`SCENARIOS` (one flux) or :data:`MIXED_SCENARIOS` (fluxes differ)
    reflectance : float
        Reflectance of all surfaces (0: direct light only).
    interreflection : bool, optional
        Include interreflected light in the targets (default: reflectance > 0).

    Returns
    -------
    scene : Scene with per-vertex targets
    luminaires : list of Luminaire (the known answer)
    """
    builders = {**_BUILDERS, **_MIXED}
    if name not in builders:
        raise KeyError(f"unknown scenario {name!r}; known: "
                       f"{', '.join(SCENARIOS + MIXED_SCENARIOS)}")
    scene, lums = builders[name](reflectance, cell)
    if interreflection is None:
        interreflection = reflectance > 0
    lux = render(scene, lums, interreflection=interreflection, backend=backend)
    return scene.with_vertex_lux(lux), lums


def match(found, true, radius=0.5):
    """Pair found luminaires with true ones (greedy nearest, within ``radius`` metres).

    Returns
    -------
    dict with ``found`` (matched count), ``true`` (count), ``spurious`` (unmatched found),
    ``errors_cm`` (list per matched true luminaire), ``max_error_cm``.
    """
    tp = [np.asarray(t.position) for t in true]
    fp = [np.asarray(f.position) for f in found]
    pairs = sorted(((np.linalg.norm(a - b), i, j) for i, a in enumerate(tp)
                    for j, b in enumerate(fp)), key=lambda x: x[0])
    used_t, used_f, errors = set(), set(), {}
    for d, i, j in pairs:
        if d > radius or i in used_t or j in used_f:
            continue
        used_t.add(i)
        used_f.add(j)
        errors[i] = d * 100
    errs = [errors[i] for i in sorted(errors)]
    return {"found": len(errors), "true": len(true), "spurious": len(fp) - len(used_f),
            "errors_cm": [round(e, 2) for e in errs],
            "max_error_cm": round(max(errs), 2) if errs else None}

"""Where a luminaire may go and where a peak puts it: convexity and occluders of a room,
the furniture zone above work planes, the clearance from a surface's border, the pull
towards mounting surfaces."""
import numpy as np

from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.inverse.refine import Light
from invrad_wb.core.inverse.locate_settings import MOUNT_CLEARANCE_M, WORK_PLANE_CLEARANCE_M


def room_is_convex(scene, tol=1e-6):
    """True if no plane of the (single-room) scene has room geometry behind it."""
    return len(occluding_faces(scene, tol)) == 0


def occluding_faces(scene, tol=1e-6):
    """Faces of planes that have some of the room's vertices behind them.

    Only these can block a segment between two points of the room: if all vertices lie in
    front of a plane, so does every point of their convex hull.
    """
    real = ~scene.face_virtual
    verts = scene.vertices[np.unique(scene.faces[real])]
    size = float(np.max(verts.max(0) - verts.min(0)))
    out = []
    for p in scene.planes:
        if p.is_virtual:
            continue
        if np.min(p.signed_distance(verts)) < -tol * max(size, 1.0) - 1e-6:
            out.append(p.faces)
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _occluders(scene, s):
    """BVH of the faces that can occlude within the room (None: no occlusion test)."""
    if s.occlusion is False:
        return None
    faces = occluding_faces(scene) if s.occlusion == "auto" else scene.occluder_faces
    return BVH(scene.triangles[faces]) if len(faces) else None


def _visible_from_brightest(scene, points, canvas, top_fraction=0.95):
    """Planes with a vertex in front of one of the brightest points (thesis 4.2.1)."""
    lux = points.lux
    bright = np.flatnonzero(lux >= top_fraction * lux.max())
    keep = set()
    for p in scene.planes:
        if p.is_virtual:
            continue
        v = scene.vertices[scene.faces[p.faces]].reshape(-1, 3)
        for b in bright[:64]:
            d = v - points.positions[b]
            if np.any(d @ points.normals[b] > 1e-6):
                keep.add(p.index)
                break
    return keep


def _light_from_peak(peak, canvas, flux=None):
    """A refinement candidate at a vote peak; a peak of a free-flux ladder (it has a
    ``flux`` of its own) starts with that flux (relative to the problem's ``flux``)."""
    m = canvas.maps[peak.map_index]
    scale = 1.0
    if getattr(peak, "flux", None) is not None and flux:
        scale = float(peak.flux) / float(flux)
    if peak.kind == "surface":
        return Light(kind="surface", position=peak.position.copy(), normal=peak.normal.copy(),
                     map_index=peak.map_index, plane=peak.plane, peak_score=peak.score,
                     origin=m.origin.copy(), u=m.u.copy(), v=m.v.copy(), flux_scale=scale)
    return Light(kind="free", position=peak.position.copy(), normal=peak.normal.copy(),
                 map_index=peak.map_index, peak_score=peak.score, flux_scale=scale)


def work_plane_height(scene):
    """Height of the highest horizontal virtual (work) plane of a scene, or -inf."""
    z = [float(scene.vertices[scene.faces[p.faces]][:, :, 2].max()) for p in scene.planes
         if p.is_virtual and abs(p.normal[2]) > 0.99]
    return max(z) if z else -np.inf


def _exclude_furniture_zone(scene, canvas):
    """No luminaire below a room's work plane (plus a clearance): desks and tables.

    Masks out surface-map pixels (walls) below the work plane height; the refinement keeps
    luminaires above it too (``canvas.min_z``).
    """
    z0 = work_plane_height(scene) + WORK_PLANE_CLEARANCE_M
    canvas.min_z = z0
    if not np.isfinite(z0):
        return
    for m in canvas.maps:
        if m.kind == "surface":
            m.mask &= m.pixel_centres()[:, :, 2] > z0
        elif m.height <= z0:
            m.mask[...] = False


def _clear_of_border(canvas, light, clearance=MOUNT_CLEARANCE_M, steps=4):
    """A surface luminaire moved to ``clearance`` inside its faces' border, or None.

    The border is probed along the map's +-u, +-v axes (``steps`` probes each): where it is
    nearer than ``clearance`` the luminaire moves away from it by the difference (to within
    ``clearance / steps``); None if it is then still not clear (a face too narrow).
    """
    m = canvas.maps[light.map_index]
    p = light.position
    if _clear_inside(m, p, clearance):
        return light
    dirs = (m.u, -m.u, m.v, -m.v)
    # the luminaire and its four probes at the clearance in one test, then the nearer
    # probes of the directions where that one is off (the same points as one by one:
    # single-point tests were a sixth of a refinement's time)
    inside = canvas.map_contains_all(light.map_index,
                                     np.array([p] + [p + clearance * d for d in dirs]))
    if not inside[0]:
        return None
    if inside[1:].all():
        return light
    off = [d for n, d in enumerate(dirs) if not inside[1 + n]]
    steps_in = canvas.map_contains_all(light.map_index, np.array(
        [p + (k / steps) * clearance * d for d in off for k in range(1, steps)]))
    shift = np.zeros(3)
    for n, d in enumerate(off):
        free = 0.0
        for k in range(1, steps):
            if not steps_in[n * (steps - 1) + k - 1]:
                break
            free = k / steps * clearance
        shift -= (clearance - free) * d
    q = p + shift
    checks = [q + s * d for s in (0.0, clearance - clearance / steps) for d in dirs]
    if not canvas.map_contains_all(light.map_index, np.array(checks)).all():
        return None
    out = light.copy()
    out.position = q
    return out


def _clear_inside(m, p, clearance):
    """Whether every pixel within ``clearance`` (and one pixel more) of ``p`` on surface
    map ``m`` is a valid pixel inside its faces (:attr:`FaceTest.inner`): then every probe
    of :func:`_clear_of_border` lies on the faces and the luminaire stays where it is (the
    same answer without the probes one by one: each LM step of ``--aim free`` asks this of
    every luminaire, 62,000 map tests and 14 of 140 s in a profile of bench_aim's
    free-flux lobby)."""
    d = np.asarray(p, dtype=np.float64) - m.origin
    i = int(np.floor((d @ m.u) / m.pixel))
    j = int(np.floor((d @ m.v) / m.pixel))
    r = int(np.ceil(clearance / m.pixel)) + 1
    if i - r < 0 or j - r < 0 or i + r >= m.shape[0] or j + r >= m.shape[1]:
        return False
    box = (slice(i - r, i + r + 1), slice(j - r, j + r + 1))
    if not m.mask[box].all():
        return False
    return m.face_test is None or bool(m.face_test.inner[box].all())


def _make_inside(canvas):
    min_z = getattr(canvas, "min_z", -np.inf)

    def inside(light):
        if light.position[2] <= min_z:
            return None
        if light.kind == "surface":
            return _clear_of_border(canvas, light)
        if canvas.grid is None:
            return None
        p = canvas.grid.clamp(light.position)
        if p is None:
            return None
        if np.array_equal(p, light.position):
            return light
        q = light.copy()
        q.position = p
        return q
    return inside


def _prefer_mounted(prob, lights, canvas, optimiser, reach=0.6, tolerance=0.02):
    """Try each mid-air luminaire as mounted on a nearby surface; keep that if not worse.

    A pendant a few centimetres from a ceiling explains the light almost as well as a
    luminaire on it (and a tilted ceiling's luminaire almost like a pendant facing down);
    a mounted luminaire is the simpler, more common answer, so it wins unless the pendant
    is better by more than ``tolerance`` of what the luminaire explains at all (the cost
    without it minus the cost with it; the other luminaires' residual errors do not count).
    """
    opt = prob.levenberg_marquardt if optimiser == "lm" else prob.evolution_strategy
    out = list(lights)
    for i, L in enumerate(out):
        if L.kind != "free":
            continue
        others = out[:i] + out[i + 1:]
        fixed = prob.fixed_light(others)
        c_free = prob.cost([L], extra=fixed)
        explains = max(prob.cost([], extra=fixed) - c_free, 0.0)
        best = None
        for k, m in enumerate(canvas.maps):
            if m.kind != "surface" or m.normal @ L.normal < 0.5:
                continue
            dist = L.position @ m.normal + m.offset
            if not (-1e-6 <= dist <= reach):
                continue
            p = L.position - dist * m.normal
            if not canvas.map_contains(k, p):
                continue
            cand = Light(kind="surface", position=p, normal=m.normal.copy(), map_index=k,
                         plane=m.plane, peak_score=L.peak_score, origin=m.origin.copy(),
                         u=m.u.copy(), v=m.v.copy(), indirect=L.indirect,
                         flux_scale=L.flux_scale, free_flux=L.free_flux)
            got, c = opt([cand], fixed=fixed)
            if c <= c_free + tolerance * explains and (best is None or c < best[1]):
                best = (got[0], c)
        if best is not None:
            out[i] = best[0]
    return out


def _snap_to_surfaces(lights, canvas, scene, tol=0.05):
    """Mid-air luminaires within ``tol`` of a surface facing the same way become mounted."""
    out = []
    for L in lights:
        if L.kind == "free":
            for k, m in enumerate(canvas.maps):
                if m.kind != "surface" or m.normal @ L.normal < 0.999:
                    continue
                dist = L.position @ m.normal + m.offset
                if -1e-6 <= dist < tol:
                    p = L.position - dist * m.normal
                    if canvas.map_contains(k, p):
                        L = Light(kind="surface", position=p, normal=m.normal.copy(),
                                  map_index=k, plane=m.plane, peak_score=L.peak_score,
                                  score=L.score, origin=m.origin.copy(), u=m.u.copy(),
                                  v=m.v.copy(), flux_scale=L.flux_scale,
                                  free_flux=L.free_flux)
                        break
        out.append(L)
    return out

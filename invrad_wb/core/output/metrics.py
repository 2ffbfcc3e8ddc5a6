"""Target vs achieved metrics of a set of faces (a room, a work plane, one plane).

Values live on the mesh vertices and vary linearly over each triangle; the metrics
integrate that field over the faces exactly (EN 12464-1 vocabulary):

* a face *has a target* when all three corners have one (NaN = no target); it is a *shade*
  face when all three targets are 0 lx ("must stay dark"), a *lit* face when all three are
  above 0, else a *transition* face (the edge between lit and shade);
* ``target_em`` / ``em``: area-weighted mean target / achieved illuminance over the lit
  faces (lux); ``target_emin``/``emin``, ``target_emax``/``emax``: extremes over their
  corners (the target points); uniformity ``u0 = emin / em``; ``emin_*``: where the
  darkest achieved target point is;
* deviations are taken over lit and transition faces: ``rmse_lux`` = sqrt(mean over the
  area of (E - T)^2), ``rmse_pct`` = it in % of ``target_em``; ``mae_lux`` / ``mae_pct``
  the mean absolute deviation likewise; ``bias_pct`` = (em - target_em) / target_em;
* ``within_tol_pct``: % of that area where |E - T| <= tolerance x T (default 20 %);
* ``max_dev_*``: the target point (T > 0) with the largest |E - T| in lux (signed: > 0
  too bright), in % of its target, and where: 3-D point, plane, words
  ("floor at (2.10, 1.35) m"); ``max_rel_dev_*``: the point with the largest relative
  deviation among points whose target is at least 10 % of ``target_em``;
* shade: ``shade_area_m2``, ``shade_max_lux`` (brightest achieved point on shade faces)
  and where, ``shade_mean_lux``.

:func:`room_metrics` computes them over any set of faces (a room, a work plane, one plane).
"""
import math

import numpy as np

from invrad_wb.errors import SceneError
from invrad_wb.core.output.images import describe_plane, room_floor_z

#: default tolerance of ``within_tol_pct``
TOLERANCE = 0.2
#: points whose target is below this fraction of the target mean are not candidates for
#: the largest *relative* deviation (soft edges of a target would always win)
REL_DEV_MIN_TARGET = 0.1

_NAN = float("nan")


# ---------------------------------------------------------------------------- words
def describe_point(scene, plane, point, floor_z=None):
    """Where a point is, in words: 'floor at (2.10, 1.35) m', 'wall x = 0.00 m (facing +x)
    at y = 1.20 m, 1.50 m above the floor'.

    Parameters
    ----------
    scene : Scene
    plane : Plane or int (plane index)
    point : (3,) float64, metres
    floor_z : float, the room's floor height (default: from the scene)
    """
    if not hasattr(plane, "normal"):
        plane = scene.planes[int(plane)]
    if floor_z is None:
        floor_z = room_floor_z(scene, plane.room)
    what = describe_plane(plane, floor_z)
    x, y, z = (float(c) for c in point)
    if abs(plane.normal[2]) > 0.9:
        return f"{what} at ({x:.2f}, {y:.2f}) m"
    h = f"{z - floor_z:.2f} m above the floor"
    if what.startswith("wall x ="):
        return f"{what} at y = {y:.2f} m, {h}"
    if what.startswith("wall y ="):
        return f"{what} at x = {x:.2f} m, {h}"
    return f"{what} at ({x:.2f}, {y:.2f}) m, {h}"


# ---------------------------------------------------------------------------- metrics
def _abs_integral(d, area):
    """Exact integral of |f| over triangles where f is linear with corner values d (k, 3)."""
    total = d.sum(axis=1) / 3.0
    out = np.abs(total) * area
    pos = d > 0
    neg = d < 0
    mixed = pos.any(axis=1) & neg.any(axis=1)
    if mixed.any():
        dm = d[mixed]
        pm = dm > 0
        # the corner whose sign is alone: positive if exactly one positive corner
        lone_pos = pm.sum(axis=1) == 1
        lone = np.where(lone_pos, np.argmax(pm, axis=1), np.argmax(dm < 0, axis=1))
        k = np.arange(len(dm))
        p = dm[k, lone]
        q = dm[k, (lone + 1) % 3]
        r = dm[k, (lone + 2) % 3]
        # sub-triangle at the lone corner, cut where f = 0 on its two edges
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = np.where(q != p, p / (p - q), 0.0)
            t2 = np.where(r != p, p / (p - r), 0.0)
        i_sub = t1 * t2 * p / 3.0          # integral over the sub-triangle / face area
        i_all = (p + q + r) / 3.0
        out[mixed] = np.sign(p) * (2.0 * i_sub - i_all) * area[mixed]
    return out


def grid_spacing(d):
    """EN 12464-1 maximum grid spacing ``p = 0.2 * 5^log10(d)`` (metres) for an area whose
    longer dimension is ``d`` metres (``p`` at most 10 m)."""
    d = max(float(d), 1e-3)
    return min(10.0, 0.2 * 5.0 ** math.log10(d))


def _sub_barycentric(k=4):
    """Centroids of the k^2 equal sub-triangles of a triangle: (k^2, 3) barycentric."""
    pts = []
    for i in range(k):
        for j in range(k - i):
            pts.append(((i + 1 / 3) / k, (j + 1 / 3) / k))          # upward sub-triangle
            if i + j < k - 1:
                pts.append(((i + 2 / 3) / k, (j + 2 / 3) / k))      # downward one
    a = np.array(pts)
    return np.stack([a[:, 0], a[:, 1], 1 - a[:, 0] - a[:, 1]], axis=1)


def _empty_metrics():
    m = {k: _NAN for k in (
        "target_em", "em", "target_emin", "emin", "target_emax", "emax", "target_u0", "u0",
        "rmse_lux", "rmse_pct", "mae_lux", "mae_pct", "bias_pct", "within_tol_pct",
        "max_dev_lux", "max_dev_pct", "max_rel_dev_lux", "max_rel_dev_pct",
        "shade_max_lux", "shade_mean_lux")}
    for k in ("max_dev", "max_rel_dev", "emin", "shade_max"):
        m[f"{k}_point"] = [_NAN, _NAN, _NAN]
        m[f"{k}_plane"] = -1
        m[f"{k}_where"] = ""
    return m


def room_metrics(scene, target_vertex_lux, achieved_vertex_lux, faces=None,
                 tolerance=TOLERANCE):
    """Target vs achieved metrics over a set of faces (see the module docstring).

    Parameters
    ----------
    scene : Scene
    target_vertex_lux : (n,) float64, lux per scene vertex; NaN = no target, 0 = shade
    achieved_vertex_lux : (n,) float64, lux per scene vertex
    faces : (k,) int, optional
        The faces to evaluate (a room, a work plane, a plane); default all faces.
    tolerance : float, fraction for ``within_tol_pct``

    Returns
    -------
    dict of floats (NaN where undefined, e.g. the lit metrics of a shade-only set), points
    as [x, y, z] lists (metres), plane indices and descriptions; counts ``n_faces``
    (faces with a target), ``n_lit_faces``, ``n_transition_faces``, ``n_shade_faces``,
    ``n_points`` (target points > 0 lx) and areas ``area_m2``, ``lit_area_m2``,
    ``shade_area_m2``.

    Raises
    ------
    SceneError
        Arrays of the wrong length, or an achieved value that is NaN/negative where
        there is a target.
    """
    n = len(scene.vertices)
    tv = np.asarray(target_vertex_lux, dtype=np.float64).reshape(-1)
    ev = np.asarray(achieved_vertex_lux, dtype=np.float64).reshape(-1)
    if len(tv) != n or len(ev) != n:
        raise SceneError(f"report: {len(tv)} target and {len(ev)} achieved values for"
                         f" {n} scene vertices", scene.source)
    faces = (np.arange(len(scene.faces)) if faces is None
             else np.asarray(faces, dtype=np.int64).reshape(-1))
    corners = scene.faces[faces]
    T, E = tv[corners], ev[corners]
    has = np.all(np.isfinite(T), axis=1)
    bad = has[:, None] & ~np.isfinite(E)
    if bad.any():
        v = int(corners[bad][0])
        raise SceneError(f"report: achieved illuminance at vertex {v} is {ev[v]} where"
                         " there is a target", scene.source)
    shade = has & np.all(T == 0, axis=1)
    lit = has & np.all(T > 0, axis=1)
    err = has & ~shade                       # lit and transition (lit/shade edge) faces
    area = scene.face_areas[faces]
    out = _empty_metrics()
    out.update(n_faces=int(has.sum()), n_lit_faces=int(lit.sum()),
               n_transition_faces=int((err & ~lit).sum()), n_shade_faces=int(shade.sum()),
               area_m2=float(area[has].sum()), lit_area_m2=float(area[lit].sum()),
               shade_area_m2=float(area[shade].sum()), n_points=0,
               tolerance_pct=100.0 * tolerance)
    where = _Where(scene)
    f = _FaceSet(corners, tv, ev, T, E, area)
    if err.any():
        # Em, Emin, Emax, U0 over the lit faces (the task area proper; transition faces
        # only if there is nothing else), deviations over lit and transition faces
        _lit_metrics(out, f, lit if lit.any() else err, where)
        _deviation_metrics(out, f, err, where, tolerance)
    if shade.any():
        _shade_metrics(out, f, shade, where)
    return out


class _Where:
    """Where a vertex is: its 3-D point, plane and words (floor heights cached per room)."""

    def __init__(self, scene):
        self.scene, self.floor_z = scene, {}

    def __call__(self, v):
        s = self.scene
        pl = int(s.vertex_plane[v])
        room = s.planes[pl].room
        if room not in self.floor_z:
            self.floor_z[room] = room_floor_z(s, room)
        p = s.vertices[v]
        return [float(x) for x in p], pl, describe_point(s, pl, p, self.floor_z[room])


class _FaceSet:
    """The faces evaluated: corners (k, 3), per-vertex target/achieved (n,), per-corner
    T, E (k, 3), face areas (k,)."""

    def __init__(self, corners, tv, ev, T, E, area):
        self.corners, self.tv, self.ev, self.T, self.E, self.area = \
            corners, tv, ev, T, E, area


def _lit_metrics(out, f, core, where):
    """Em, Emin, Emax, U0 (target and achieved) over the faces ``core`` (bool mask)."""
    Ac = f.area[core]
    t_em = float((Ac * f.T[core].mean(axis=1)).sum() / Ac.sum())
    e_em = float((Ac * f.E[core].mean(axis=1)).sum() / Ac.sum())
    vc = np.unique(f.corners[core].reshape(-1))
    vc = vc[f.tv[vc] > 0]
    out.update(target_em=t_em, em=e_em, target_emin=float(f.tv[vc].min()),
               target_emax=float(f.tv[vc].max()), emin=float(f.ev[vc].min()),
               emax=float(f.ev[vc].max()))
    out["target_u0"] = out["target_emin"] / t_em if t_em > 0 else _NAN
    out["u0"] = out["emin"] / e_em if e_em > 0 else _NAN
    j = vc[int(np.argmin(f.ev[vc]))]
    out["emin_point"], out["emin_plane"], out["emin_where"] = where(j)


def _deviation_metrics(out, f, err, where, tolerance):
    """RMSE, MAE, bias, largest deviations and the area within tolerance over ``err``."""
    t_em, e_em = out["target_em"], out["em"]
    Tl, El, Al = f.T[err], f.E[err], f.area[err]
    A = float(Al.sum())
    d = El - Tl
    sq = (d ** 2).sum(axis=1) + d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 2] * d[:, 0]
    rmse = float(np.sqrt(max((Al * sq / 6.0).sum() / A, 0.0)))
    mae = float(_abs_integral(d, Al).sum() / A)
    out.update(rmse_lux=rmse, mae_lux=mae)
    if t_em > 0:
        out["rmse_pct"] = 100.0 * rmse / t_em
        out["mae_pct"] = 100.0 * mae / t_em
        out["bias_pct"] = 100.0 * (e_em - t_em) / t_em
    verts = np.unique(f.corners[err].reshape(-1))
    verts = verts[f.tv[verts] > 0]
    tp, ep = f.tv[verts], f.ev[verts]
    out["n_points"] = int(len(verts))
    dev = ep - tp
    i = int(np.argmax(np.abs(dev)))
    out["max_dev_lux"] = float(dev[i])
    out["max_dev_pct"] = float(100.0 * dev[i] / tp[i])
    exact = dev[i] == 0                   # no deviation anywhere: no place to name
    if not exact:
        out["max_dev_point"], out["max_dev_plane"], out["max_dev_where"] = where(verts[i])
    cand = np.flatnonzero(tp >= REL_DEV_MIN_TARGET * t_em)
    if len(cand) and not exact:
        j = cand[int(np.argmax(np.abs(dev[cand]) / tp[cand]))]
        out["max_rel_dev_lux"] = float(dev[j])
        out["max_rel_dev_pct"] = float(100.0 * dev[j] / tp[j])
        (out["max_rel_dev_point"], out["max_rel_dev_plane"],
         out["max_rel_dev_where"]) = where(verts[j])
    # area within tolerance: sampled at the centroids of 16 sub-triangles per face;
    # where the target is 0 (transition faces) "within" means E <= tolerance x Em
    B = _sub_barycentric(4)
    ts, es = Tl @ B.T, El @ B.T
    ok = np.abs(es - ts) <= tolerance * np.where(ts > 0, ts, t_em) + 1e-12
    out["within_tol_pct"] = float(100.0 * (Al * ok.mean(axis=1)).sum() / A)


def _shade_metrics(out, f, shade, where):
    """Mean and brightest achieved light on the shade faces, and where."""
    As = f.area[shade]
    out["shade_mean_lux"] = float((As * f.E[shade].mean(axis=1)).sum() / As.sum())
    verts = np.unique(f.corners[shade].reshape(-1))
    j = verts[int(np.argmax(f.ev[verts]))]
    out["shade_max_lux"] = float(f.ev[j])
    out["shade_max_point"], out["shade_max_plane"], out["shade_max_where"] = where(j)


def relative_deviation(target_vertex_lux, achieved_vertex_lux, reference_lux):
    """Per-vertex deviation as a fraction: (E - T) / T; on shade (T = 0) E / reference.

    A target below :data:`REL_DEV_MIN_TARGET` of the reference (the rim of a spot fading
    to nothing) is judged against that fraction of the reference instead of itself:
    (E - T) / max(T, 0.1 reference). Relative to its own few lux the light a spot's rim
    gets from the luminaire lighting the spot read as +200 % and more, a saturated ring
    around every spot; the report's largest relative deviation leaves such points out
    for the same reason.

    Parameters
    ----------
    reference_lux : float or (n,) float64, the mean target used for shade points
        (NaN: shade points get NaN, and no floor applies)

    Returns
    -------
    (n,) float64, NaN where there is no target.
    """
    t = np.asarray(target_vertex_lux, dtype=np.float64)
    e = np.asarray(achieved_vertex_lux, dtype=np.float64)
    ref = np.broadcast_to(np.asarray(reference_lux, dtype=np.float64), t.shape)
    out = np.full(t.shape, np.nan)
    lit = np.isfinite(t) & (t > 0)
    floor = np.where(np.isfinite(ref) & (ref > 0), REL_DEV_MIN_TARGET * ref, 0.0)
    out[lit] = (e[lit] - t[lit]) / np.maximum(t[lit], floor[lit])
    sh = np.isfinite(t) & (t == 0) & np.isfinite(ref) & (ref > 0)
    out[sh] = e[sh] / ref[sh]
    return out


#: the highest uniformity EN 12464-1 asks of a task area: a uniform target (U0 = 1) asks
#: for this, not for more
U0_CAP = 0.7


def verdict(m, tolerance=TOLERANCE):
    """Does a set of faces meet its targets? (the report's pass/fail, per room)

    * Em: the achieved mean within ``tolerance`` of the target mean;
    * U0: the achieved uniformity at least ``min((1 - tolerance) x target U0, U0_CAP)``
      (a uniform target asks for EN 12464-1's highest class, 0.7, not for 0.8);
    * shade: the brightest shade point at most ``tolerance`` times the target mean (the
      rule ``within_tol_pct`` applies where the target is 0).

    Parameters
    ----------
    m : dict from :func:`room_metrics`

    Returns
    -------
    dict: ``em``, ``u0``, ``shade`` (bool, or None where there is nothing to judge),
    ``u0_required`` (float or NaN) and ``ok`` (all judged parts pass; None when nothing
    was judged)
    """
    te, tu = m.get("target_em", _NAN), m.get("target_u0", _NAN)
    em = bool(abs(m["em"] - te) <= tolerance * te + 1e-9) if np.isfinite(te) else None
    u0_req = min((1 - tolerance) * tu, U0_CAP) if np.isfinite(tu) else _NAN
    u0 = (bool(m["u0"] >= u0_req - 1e-9)
          if np.isfinite(u0_req) and np.isfinite(m["u0"]) else None)
    shade = None
    if m.get("n_shade_faces") and np.isfinite(te):
        shade = bool(m["shade_max_lux"] <= tolerance * te + 1e-9)
    judged = [x for x in (em, u0, shade) if x is not None]
    return {"em": em, "u0": u0, "shade": shade, "u0_required": u0_req,
            "ok": all(judged) if judged else None}

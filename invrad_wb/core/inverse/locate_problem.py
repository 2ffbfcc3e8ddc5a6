"""One room's problem: the ambient estimate, the vote function (votes as if each luminaire
had a share of the light), the refinement problem with its interreflection model, and the
flux ladder of a run without a given flux."""
import time

import numpy as np

from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.inverse.peaks import find_peaks
from invrad_wb.core.inverse.refine import RefineProblem
from invrad_wb.core.inverse.votes import vote_weights, cast_exact, vote_profile
from invrad_wb.core.inverse.locate_placement import _make_inside


def _ambient_estimate(scene, points):
    """Mean interreflected illuminance of a closed diffuse room: rho_mean * E_mean.

    From flux balance: with mean incident illuminance E and mean reflectance rho, the
    reflected flux rho E S comes back as interreflected light, so indirect ~ rho * E.
    Only meaningful when the targets cover most of the room (complete illumination).
    """
    real = ~scene.face_virtual
    area = scene.face_areas[real]
    covered = float(np.sum(points.area))
    if covered < 0.5 * area.sum() or len(points) == 0:
        return 0.0
    rho = float(np.average(scene.face_reflectance[real], weights=area))
    return rho * float(np.average(points.lux, weights=points.area))


def _uniform_indirect_per_lumen(scene):
    """Mean interreflected illuminance per lumen in a closed room: rho / (S (1 - rho)).

    (CIE 171 / the integrating-sphere balance: a flux F reflected with mean reflectance rho
    comes back as rho F / (1 - rho) spread over the surface area S.)
    """
    real = ~scene.face_virtual
    area = scene.face_areas[real]
    rho = float(np.average(scene.face_reflectance[real], weights=area))
    return rho / (area.sum() * max(1.0 - rho, 1e-3))


class _Indirect:
    """Interreflected light at the voting points for a set of luminaires (radiosity)."""

    def __init__(self, scene, points, backend, photometry=None, bvh=None):
        from invrad_wb.core.forward.radiosity import RadiosityModel
        self.photometry = photometry
        self.scene = scene
        self.backend = backend
        # the room's own occluders (the refinement's: none in a convex room), not a second
        # BVH of every face (it cost 15 % of a room's CPU time with interreflection)
        self.bvh = bvh
        self.model = RadiosityModel.for_scene(scene, backend=backend)
        patch = self.model.face_patch[points.face]
        self.gather = self.model.gather(points.positions, points.normals, patch)

    def exitance(self, lights, flux):
        """(P,) patch exitance of ``lights`` together, each of ``flux`` lm."""
        from invrad_wb.core.model.aiming import aimed_c0
        lums = [Luminaire(L.position, L.normal, flux, photometry=self.photometry,
                          c0=None if L.mount is None else aimed_c0(L.mount, L.normal))
                for L in lights]
        # each patch's mean direct light, exact near a luminaire (as the verification's)
        pdir = self.model.patch_direct(lums, bvh=self.bvh, occlusion=self.bvh is not None,
                                       backend=self.backend)
        return self.model.solve(pdir)

    def __call__(self, lights, flux):
        B = self.exitance(lights, flux)
        g = self.gather
        return g(B) if callable(g) else g @ B


def _vote_function(canvas, pts, ambient, occ, s, flux, backend, timings, photometry=None):
    """``vote_fn(share=1, lux=None)``: the votes (canvas.size,) float32 of the voting points
    as if ``1/share`` of each point's light came from one luminaire of ``flux`` lm (of the
    ``photometry`` distribution, averaged over its C planes, with the exact model; the
    thesis' ellipses are lambertian).

    The ambient (interreflected) estimate, lux, is taken off the targets first; points
    with 0 lx are shade (no luminaire may light them above the shade limit).
    """
    lit = pts.lux > 0
    shade = pts.subset(pts.lux == 0)
    vote_lux = np.where(lit, np.maximum(pts.lux - ambient, 0.0), 0.0)
    # a point barely above the ambient level carries no position information
    vote_lux[vote_lux < 0.05 * pts.lux] = 0.0
    profile = vote_profile(photometry)
    shade_limit = s.shade_limit_lux
    if shade_limit is None and len(shade):
        shade_limit = max(1.0, 0.1 * float(np.median(pts.lux[lit])))

    def vote_fn(share=1, lux=None):
        """``lux``: (k,) illuminance to vote with instead of the targets less the ambient
        estimate (e.g. what accepted luminaires leave unexplained)."""
        t0 = time.time()
        vl = (vote_lux if lux is None else np.asarray(lux, dtype=np.float64)) / share
        W = vote_weights(canvas, pts, vl, s.weighting, s.vote_strength)
        if s.vote_model == "exact":
            out = cast_exact(canvas, pts, W, vl, flux, backend=backend, bvh=occ,
                             shade=shade, shade_limit_lux=shade_limit, profile=profile)
        else:
            from invrad_wb.core.inverse.votes_ellipse import cast_ellipse
            out = cast_ellipse(canvas, pts, W, vl, flux, bvh=occ, shade=shade,
                               shade_limit_lux=shade_limit, backend=backend)
        timings["votes"] += time.time() - t0
        return out
    return vote_fn


def _at_vertices(scene, pts):
    """The voting points moved to the nearest corner of their face where the targets are
    per vertex: there the target is the given value itself, not a linear interpolation
    between corners of a light that falls off as 1/r^2 (which the refinement's model
    cannot match: measured, three 2000 lm downlights 0.75 m apart at 2.5 m, direct light,
    0.25 m mesh: the true arrangement left a 1.3 % RMS log residual and, refitted with free
    fluxes, drifted 10-17 cm and 20-35 % in flux; at the corners it leaves none). A point
    goes to its nearest lit corner (a wall point just below a ceiling lit from it, between
    a lit corner and a dark one at the ceiling's edge, was the true arrangement's largest
    residual); a point with no such corner keeps its place. Other targets (per face, a
    texture): the points as they are.
    """
    if getattr(scene, "vertex_lux", None) is None or len(pts) == 0:
        return pts
    from invrad_wb.core.inverse.sampling import VotingPoints
    corners = scene.vertex_lux[scene.faces[pts.face]]                    # (k, 3)
    good = np.isfinite(corners) & ((corners > 0) == (pts.lux > 0)[:, None])
    j = np.argmax(np.where(good, pts.bary + 1e-9, -1.0), axis=1)
    v = scene.faces[pts.face, j]
    lux = scene.vertex_lux[v]
    ok = good[np.arange(len(j)), j]
    bary = np.where(ok[:, None], np.eye(3)[j], pts.bary)
    return VotingPoints(np.where(ok[:, None], scene.vertices[v], pts.positions), pts.normals,
                        pts.face, pts.plane, bary, np.where(ok, lux, pts.lux), pts.area,
                        pts.density)


#: :func:`vertex_points`: at most this many target vertices (an even random subset of a
#: room meshed more finely; a refit's time grows with the points) in the last refit's
#: problem on which regroup works; the refit after it takes every target vertex, streamed
#: in chunks (:meth:`~invrad_wb.core.inverse.locate_fit._RoomFit.polish_every_vertex`,
#: at most :data:`~invrad_wb.core.inverse.locate_vertices.VERTICES_MAX`)
VERTEX_POINTS_MAX = 20000


def target_vertex_count(scene):
    """How many vertices of ``scene``'s faces carry a target (0 where the targets are not
    per vertex): :func:`vertex_points`' count before it takes a subset."""
    if getattr(scene, "vertex_lux", None) is None or len(scene.faces) == 0:
        return 0
    used = np.unique(scene.faces.reshape(-1))
    return int(np.count_nonzero(np.isfinite(scene.vertex_lux[used])))


def vertex_points(scene, most=VERTEX_POINTS_MAX, seed=0):
    """Every vertex of ``scene`` that carries a target, once, as refinement points (its
    plane's normal; the area it stands for: a third of each face around it), or None
    where the targets are not per vertex.

    The voting points (about 3000 per room, :func:`~invrad_wb.core.inverse.sampling.
    default_density`) use part of a large room's data: a 10 x 9 x 3 m room meshed at
    0.2 m has about 7800 target vertices. Each vertex is one measurement with its own
    noise: a fit to all of them is the more precise (the Cramer-Rao bound of twelve
    4000 lm downlights' positions with free fluxes and 5 % noise per vertex: 9.3 cm on
    the 3018 voting points at their corners, 5.8 cm on the 7796 vertices).
    """
    if getattr(scene, "vertex_lux", None) is None or len(scene.faces) == 0:
        return None
    from invrad_wb.core.inverse.sampling import VotingPoints
    corners = scene.faces.reshape(-1)
    n = len(scene.vertices)
    area = np.bincount(corners, weights=np.repeat(scene.face_areas / 3.0, 3), minlength=n)
    face = np.full(n, -1, dtype=np.int64)
    face[corners] = np.repeat(np.arange(len(scene.faces)), 3)
    keep = np.flatnonzero((face >= 0) & np.isfinite(scene.vertex_lux) & (area > 0))
    if len(keep) == 0:
        return None
    if len(keep) > most:
        keep = np.sort(np.random.default_rng(seed).choice(keep, most, replace=False))
        area_scale = float(area[face >= 0].sum()) / float(area[keep].sum())
    else:
        area_scale = 1.0
    f = face[keep]
    corner = np.argmax(scene.faces[f] == keep[:, None], axis=1)
    return VotingPoints(scene.vertices[keep].copy(), scene.face_normals[f].copy(), f,
                        scene.face_plane[f], np.eye(3)[corner], scene.vertex_lux[keep].copy(),
                        area[keep] * area_scale, float(len(keep) / area[keep].sum()))


def _refine_problem(scene, pts, canvas, occ, s, flux, backend, has_rho, timings,
                    photometry=None, at_vertices=False):
    """The joint refinement problem of a room's voting points and its radiosity model.

    ``at_vertices``: the points at their faces' corners (:func:`_at_vertices`), for a fit
    of free fluxes (close luminaires' fluxes trade against their positions, and the
    interpolation's bias sets them: measured, three 2000 lm 0.75 m apart, no noise, 12 %
    off in flux with the points as they are, exact at the corners). With the flux given
    the points stay (averaging three corners lowers the targets' noise: 5 % per vertex,
    twelve 4000 lm downlights, worst error 3.5 cm as they are, 9.5 cm at the corners).

    Returns ``(RefineProblem, _Indirect or None)``.
    """
    from invrad_wb.core.forward.occlusion import segments_occluded
    if at_vertices:
        pts = _at_vertices(scene, pts)
    occluded_fn = None if occ is None else (
        lambda p, q, _b=occ: segments_occluded(_b, p, q, backend))
    prob = RefineProblem(positions=pts.positions, normals=pts.normals, target=pts.lux,
                         flux=flux, area=pts.area, bvh=occ, inside=_make_inside(canvas),
                         occluded_fn=occluded_fn, photometry=photometry,
                         free_aim=s.aim == "free")
    indirect_model = None
    if s.indirect != "none" and has_rho:
        per_lumen = _uniform_indirect_per_lumen(scene)
        prob.indirect_estimate = lambda L, _k=len(pts), _a=per_lumen * flux: np.full(_k, _a)
    if s.indirect == "radiosity" and has_rho:
        t = time.time()
        indirect_model = _Indirect(scene, pts, backend, photometry, bvh=occ)
        prob.indirect_exact = lambda L, _m=indirect_model: _m([L], flux)
        timings["radiosity"] += time.time() - t
    return prob, indirect_model


#: with ``--aim free`` and the fluxes free, a luminaire is kept only if it also lowers the
#: cost by this fraction of the cost without any luminaire; every other selection is judged
#: against the data's noise alone (select.greedy_select)
FREE_FLUX_MIN_GAIN_TOTAL = 0.002


#: successive fluxes of the free-flux vote ladder differ by this factor
FLUX_LADDER_STEP = 2.0


#: the ladder spans need / 2**FLUX_LADDER_OCTAVES .. need (the room's lumen-method need)
FLUX_LADDER_OCTAVES = 6


#: the ladder's step with ``--aim free``: its footprint search (:mod:`.aim`) proposes
#: every luminaire whatever its flux, the votes only add candidates beside it
AIM_FREE_LADDER_STEP = 4.0


def _flux_ladder(pts, step=FLUX_LADDER_STEP):
    """Fluxes (lm) to vote with when the flux is not given, largest first.

    The top is the lamp flux the room's targets need by the lumen method (sum(E A) / 0.5,
    one luminaire doing it all); each next one is ``step`` (:data:`FLUX_LADDER_STEP`)
    smaller, down to 1/2**:data:`FLUX_LADDER_OCTAVES` of it. A luminaire of flux F gets
    sharp votes from the rung nearest F; the refinement then fits F itself.
    """
    need = float(np.sum(np.nan_to_num(pts.lux) * pts.area)) / 0.5
    n = int(round(FLUX_LADDER_OCTAVES * np.log(2.0) / np.log(step)))
    return [need / step ** k for k in range(n + 1)]


def _ladder_peaks(run, s, ladder=None):
    """Peaks of every rung of the free-flux ladder as refinement candidates.

    All rungs share the voting points and weights, so raw votes compare across rungs: the
    rung nearest a luminaire's flux gives it the sharpest, highest accumulation. But a weak
    luminaire beside a strong one has lower raw votes than the strong one's blurred peaks
    on every other rung, so the order is by rank within the rung first. Each peak carries
    its rung's flux (``peak.flux``); peaks of the same place on several rungs are all kept
    (the refinement skips those near an accepted luminaire).
    """
    out = []
    for f, votes in (run.ladder_votes if ladder is None else ladder).items():
        pk, _ = find_peaks(run.canvas, votes, threshold=s.threshold,
                           neighbourhood=s.neighbourhood_m, max_peaks=s.max_candidates)
        pk.sort(key=lambda p: -p.score)
        for rank, p in enumerate(pk):
            p.flux, p.rank = f, rank
        out += pk
    # each rung's best first (a weak luminaire is the best peak of its own rung only),
    # strongest raw votes first among equal ranks
    out.sort(key=lambda p: (p.rank, -p.votes))
    return out[:2 * s.max_candidates]

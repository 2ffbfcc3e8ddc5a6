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
"""
from dataclasses import dataclass, field, asdict
import time

import numpy as np

from invrad_wb.errors import Cancelled, SceneError, SettingsError
from invrad_wb.core.geometry.bvh import BVH
from invrad_wb.core.accel.device import check_backend
from invrad_wb.core.accel.workers import map_rooms
from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.inverse.peaks import find_peaks
from invrad_wb.core.inverse.refine import (LOG_SCALE_LIMIT, Light, RefineProblem, greedy_select,
                                          swap_search)
from invrad_wb.core.inverse.sampling import voting_points, default_density
from invrad_wb.core.inverse.votemaps import build_canvas
from invrad_wb.core.inverse.votes import vote_weights, cast_exact, vote_profile
from invrad_wb.core.inverse.fitcheck import room_fit

VOTE_MODELS = ("exact", "ellipse")
#: luminaires stay this far above a work plane (nothing is mounted right above a desk)
WORK_PLANE_CLEARANCE_M = 0.3
#: A luminaire mounted on a surface keeps its centre this far inside the border of the
#: faces it is on (a luminaire has a body: on FZK-Haus the refinement pushed ceiling lights
#: onto the ceiling's edge, their centres on the wall line, when a work plane reached to
#: the walls).
MOUNT_CLEARANCE_M = 0.1
INDIRECT_MODES = ("radiosity", "ambient", "none")
AIM_MODES = ("fixed", "free")


@dataclass
class LocateSettings:
    """Every option of a locate run. Defaults need only the flux for a typical room.

    Attributes
    ----------
    vote_model : 'exact' or 'ellipse' (the thesis' voting table)
    pixel_m : vote-map resolution, metres per pixel
    votes_per_m2 : voting point density (None: about 3000 points in the largest room)
    weighting : 'illumination', 'distance', 'both' or 'none'
    vote_strength : basic weight of each vote
    occlusion : 'auto' (when the room is not convex), True or False
    dummy_planes : vote also on horizontal mid-air layers (pendants)
    dummy_spacing_m, dummy_count, dummy_lowest_m : layers from one spacing below the
        ceiling down to ``dummy_lowest_m`` above the floor (or ``dummy_count`` layers)
    two_sided_dummies : dummy layers also hold upward-facing luminaires
    all_planes : vote to all planes (False: only to planes visible from the brightest spots)
    threshold : 0-254, peaks kept after joint scaling
    neighbourhood_m : non-maxima suppression radius, metres
    refine : jointly refine the peaks (False: report the thesis' raw peaks)
    optimiser : 'lm' (Levenberg-Marquardt) or 'es' ((1+1) evolution strategy)
    indirect : 'radiosity' (forward radiosity solve), 'ambient' (constant term) or 'none'
    min_gain : a peak is kept if it lowers the refinement cost by this fraction
    max_candidates : at most this many peaks are tried per room
    overlap_levels : when the fit stays poor, vote again as if each point's light came
        from 2, 3 ... of this many luminaires (the thesis' workaround for overlapping light,
        5.2: search with a multiple of the flux) for more candidates; 1 disables it
    poor_fit : mean absolute log deviation above which the fit counts as poor
    shade_limit_lux : a luminaire position is forbidden if it would put more than this on
        a point that must stay dark (None: 10 % of the median target, at least 1 lx)
    seed : seed of the voting point pattern offsets
    aim : 'fixed' (each luminaire faces along its mounting surface's normal) or 'free'
        (each mounted luminaire's aim is fitted too: adjustable spots,
        :mod:`invrad_wb.core.inverse.aim`)
    max_tilt_deg : with ``aim`` 'free', the largest tilt from the mounting surface's
        normal (degrees, 0-89)
    """

    vote_model: str = "exact"
    pixel_m: float = 0.1
    votes_per_m2: float = None
    weighting: str = "illumination"
    vote_strength: float = 1.0
    occlusion: object = "auto"
    dummy_planes: bool = True
    dummy_spacing_m: float = 0.15
    dummy_count: int = None
    dummy_lowest_m: float = None
    two_sided_dummies: bool = False
    all_planes: bool = True
    threshold: float = 24.0
    neighbourhood_m: float = 0.3
    refine: bool = True
    optimiser: str = "lm"
    indirect: str = "radiosity"
    min_gain: float = 0.05
    max_candidates: int = 40
    overlap_levels: int = 4
    poor_fit: float = 0.08
    shade_limit_lux: float = None
    seed: int = 0
    aim: str = "fixed"
    max_tilt_deg: float = 70.0

    def _check_types(self):
        """Each setting has its field's type: a number is a real number (not text, not
        true/false), a switch is true/false, a name is text; None where allowed."""
        import typing
        hints = typing.get_type_hints(type(self))
        for name, f in self.__dataclass_fields__.items():
            v, kind = getattr(self, name), hints.get(name)
            if v is None and f.default is None:
                continue
            if kind is bool:
                ok = isinstance(v, (bool, np.bool_))
            elif kind in (int, float):
                ok = isinstance(v, (int, float, np.integer, np.floating)) and \
                    not isinstance(v, (bool, np.bool_))
                if ok and kind is int and not float(v).is_integer():
                    ok = False
            elif kind is str:
                ok = isinstance(v, str)
            else:
                ok = isinstance(v, (str, bool, int, float))
            if not ok:
                want = {bool: "true or false", int: "a whole number", float: "a number",
                        str: "a name"}.get(kind, "a value")
                raise SettingsError(f"{name} must be {want}, got {v!r}")

    def check(self):
        self._check_types()
        if self.vote_model not in VOTE_MODELS:
            raise SettingsError(f"vote_model must be one of {VOTE_MODELS}, got"
                                f" {self.vote_model!r}")
        if self.indirect not in INDIRECT_MODES:
            raise SettingsError(f"indirect must be one of {INDIRECT_MODES}, got"
                                f" {self.indirect!r}")
        if self.occlusion not in ("auto", True, False):
            raise SettingsError(f"occlusion must be 'auto', true or false, got"
                                f" {self.occlusion!r}")
        for name in ("pixel_m", "dummy_spacing_m", "vote_strength"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise SettingsError(f"{name} must be a positive number, got {v!r}")
        if self.votes_per_m2 is not None and not (np.isfinite(self.votes_per_m2)
                                                  and self.votes_per_m2 > 0):
            raise SettingsError(f"votes_per_m2 must be > 0, got {self.votes_per_m2!r}")
        if not 0 <= self.threshold <= 254:
            raise SettingsError(f"threshold must be in [0, 254], got {self.threshold!r}")
        if not (np.isfinite(self.neighbourhood_m) and self.neighbourhood_m >= 0):
            raise SettingsError(f"neighbourhood_m must be >= 0, got {self.neighbourhood_m!r}")
        if not (isinstance(self.overlap_levels, int) and 1 <= self.overlap_levels <= 16):
            raise SettingsError(f"overlap_levels must be an integer in 1-16, got"
                                f" {self.overlap_levels!r}")
        if self.aim not in AIM_MODES:
            raise SettingsError(f"aim must be one of {AIM_MODES}, got {self.aim!r}")
        if not (np.isfinite(self.max_tilt_deg) and 0 <= self.max_tilt_deg < 90):
            raise SettingsError(f"max_tilt_deg must be in [0, 90) degrees, got"
                                f" {self.max_tilt_deg!r}")
        if not 0 <= self.min_gain < 1:
            raise SettingsError(f"min_gain must be in [0, 1), got {self.min_gain!r}")
        return self

    @classmethod
    def from_dict(cls, d):
        if not isinstance(d, dict):
            raise SettingsError(f"locate settings must be an object of name: value, got"
                                f" {type(d).__name__}")
        known = set(cls.__dataclass_fields__)
        unknown = set(d) - known
        if unknown:
            raise SettingsError(f"unknown locate setting(s): {', '.join(sorted(unknown))}")
        return cls(**d).check()


@dataclass
class RoomRun:
    """What one room's run keeps so that post-processing can be redone without voting."""

    room: int
    scene: object
    points: object
    canvas: object
    votes: np.ndarray
    problem: object
    occluders: object
    ambient_lux: float
    indirect_model: object = None
    vote_fn: object = None            # share -> votes as if 1/share of the light per luminaire
    extra_votes: dict = field(default_factory=dict)
    #: lumens of the problem's luminaire (the given flux, or the free-flux reference)
    flux: float = None
    #: the flux was not given: each luminaire's flux is fitted; ``ladder_votes`` maps each
    #: voted flux (lm) to its votes
    free_flux: bool = False
    ladder_votes: dict = field(default_factory=dict)
    peaks: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    trace: list = field(default_factory=list)
    cost: float = float("nan")
    #: the room's name for people (progress, vote-map titles): its given name or 'room N'
    label: str = None
    #: what rebuilds ``problem``, ``indirect_model`` and ``vote_fn`` (settings, backend,
    #: photometry, has_rho): they hold closures and device objects and are not pickled
    #: (a room run on a worker process comes back without them, see :meth:`restore`)
    remake: tuple = None
    #: ``scene`` is this room's own subset (its caches may be dropped), not the caller's
    own_scene: bool = False
    #: luminaires to start a refinement from as well (:meth:`_RoomFit.seeded`)
    seeds: list = field(default_factory=list)

    def __getstate__(self):
        state = dict(self.__dict__)
        if self.remake is not None:
            state.update(problem=None, indirect_model=None, vote_fn=None)
        return state

    def detach(self):
        """Drop what :meth:`restore` can rebuild (the refinement problem, its radiosity
        model and the vote function; the room scene's radiosity cache when the scene is the
        room's own), so that a building's results take memory by votes and points only."""
        if self.remake is not None:
            self.problem = self.indirect_model = self.vote_fn = None
            if self.own_scene:
                self.scene.__dict__.pop("_radiosity", None)
        return self

    def restore(self):
        """Rebuild the refinement problem and vote function after unpickling."""
        if self.problem is not None or self.remake is None:
            return self
        s, backend, photometry, has_rho = self.remake
        t = {k: 0.0 for k in ("votes", "radiosity")}
        self.vote_fn = _vote_function(self.canvas, self.points, self.ambient_lux,
                                      self.occluders, s, self.flux, backend, t, photometry)
        self.problem, self.indirect_model = _refine_problem(
            self.scene, self.points, self.canvas, self.occluders, s, self.flux, backend,
            has_rho, t, photometry)
        self.problem.free_flux = self.free_flux
        return self


@dataclass
class LocateResult:
    """Luminaires found, the settings used, timings and per-room state.

    ``luminaires``: list of Luminaire (position, normal, flux_lm, room, score);
    ``timings``: seconds per stage (summed over rooms) and in total.
    """

    luminaires: list
    settings: dict
    timings: dict
    flux_lm: float                    # None: each luminaire's flux was fitted
    rooms: list = field(default_factory=list)
    backend: str = "numpy"

    def to_dict(self):
        return {"luminaires": [l.to_dict() for l in self.luminaires],
                "settings": self.settings, "timings": self.timings,
                "flux_lm": self.flux_lm, "backend": self.backend,
                "rooms": [{"room": int(r.room), "voting_points": len(r.points),
                           "maps": len(r.canvas.maps), "peaks": len(r.peaks),
                           "ambient_lux": r.ambient_lux, "cost": r.cost,
                           "fit": r.fit.to_dict() if getattr(r, "fit", None) else None,
                           "occluders": 0 if r.occluders is None else r.occluders.n_triangles}
                          for r in self.rooms]}

    def repeak(self, threshold=None, neighbourhood=None, progress=None):
        """Post-process the stored votes again (new threshold/neighbourhood); no re-voting."""
        s = LocateSettings(**self.settings)
        if threshold is not None:
            s.threshold = float(threshold)
        if neighbourhood is not None:
            s.neighbourhood_m = float(neighbourhood)
        s.check()
        t0 = time.time()
        for run in self.rooms:
            # a fresh problem: the result does not depend on earlier post-processing (nor
            # on whether the room ran in this process or on a worker); dropped again after
            _postprocess(run.detach().restore(), s, run.flux, progress, allow_votes=False)
            run.detach()
        self.settings = asdict(s)
        self.timings["repeak"] = time.time() - t0
        self.luminaires = _collect(self.rooms)
        return self

    def save_vote_maps(self, folder):
        """Write each map's votes (greyscale PNG, jointly scaled) and the raw EXR."""
        from invrad_wb.core.output.votemap_images import save_vote_maps
        return save_vote_maps(self, folder)


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
    if not canvas.map_contains(light.map_index, p):
        return None
    shift = np.zeros(3)
    near = False
    for d in (m.u, -m.u, m.v, -m.v):
        if canvas.map_contains(light.map_index, p + clearance * d):
            continue
        near = True
        free = 0.0
        for k in range(1, steps):
            if not canvas.map_contains(light.map_index, p + (k / steps) * clearance * d):
                break
            free = k / steps * clearance
        shift -= (clearance - free) * d
    if not near:
        return light
    q = p + shift
    if not all(canvas.map_contains(light.map_index, q + s * d)
               for s in (0.0, clearance - clearance / steps)
               for d in (m.u, -m.u, m.v, -m.v)):
        return None
    out = light.copy()
    out.position = q
    return out


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

    def __call__(self, lights, flux):
        from invrad_wb.core.model.aiming import aimed_c0
        lums = [Luminaire(L.position, L.normal, flux, photometry=self.photometry,
                          c0=None if L.mount is None else aimed_c0(L.mount, L.normal))
                for L in lights]
        # each patch's mean direct light, exact near a luminaire (as the verification's)
        pdir = self.model.patch_direct(lums, bvh=self.bvh, occlusion=self.bvh is not None,
                                       backend=self.backend)
        B = self.model.solve(pdir)
        g = self.gather
        return g(B) if callable(g) else g @ B


def _postprocess(run, s, flux, progress=None, deadline=None, allow_votes=True):
    """Peaks of one room's votes, then (``s.refine``) the joint refinement.

    Sets ``run.peaks``, ``run.lights``, ``run.cost`` and ``run.trace``. ``allow_votes``:
    whether the overlap step may vote again (False when post-processing is redone).
    """
    if run.free_flux:
        peaks = _ladder_peaks(run, s)
    else:
        peaks, _ = find_peaks(run.canvas, run.votes, threshold=s.threshold,
                              neighbourhood=s.neighbourhood_m, max_peaks=s.max_candidates)
    run.peaks = peaks
    if not s.refine:
        run.lights = [_light_from_peak(p, run.canvas) for p in peaks]
        for L in run.lights:
            L.score = L.peak_score / 255.0
        return
    fit = _RoomFit(run, s)
    cands = [_light_from_peak(p, run.canvas, flux) for p in peaks]
    if s.aim == "free":
        from invrad_wb.core.inverse.aim import aimed_candidates
        cands = aimed_candidates(run, s, cands)
    lights, cost = fit.select(cands, progress, deadline)
    # light that several luminaires share: vote again with a fraction of each point's
    # light (thesis 5.2) and offer those peaks too
    if (run.vote_fn is not None and s.overlap_levels > 1 and not run.free_flux
            and fit_quality(fit.prob, lights) > s.poor_fit):
        lights, cost = fit.overlap(lights, cost, cands, allow_votes)
    # fluxes free: a weak luminaire beside a strong one may have no clear peak on any
    # rung while the strong one's light is in the votes; vote again with what the
    # accepted luminaires leave unexplained
    if run.free_flux and run.vote_fn is not None and allow_votes and lights:
        lights, cost = fit.residual(lights, cost, cands)
    # still poor: light spread evenly by many luminaires (a uniform work plane) has no
    # accumulation points at all; seed the refinement with regular arrangements of n
    # luminaires on the ceiling and keep the best refined answer
    if s.overlap_levels > 1 and fit_quality(fit.prob, lights) > s.poor_fit:
        lights, cost = fit.grid(lights, cost, cands, flux)
    if run.seeds:
        lights, cost = fit.seeded(lights, cost, cands, run.seeds)
    lights, cost = fit.spread(lights, cost)
    # final scores: how much worse the fit is without each luminaire
    prob = fit.prob
    cost = prob.cost(lights) if lights else cost
    for i, L in enumerate(lights):
        c_rest = prob.cost(lights[:i] + lights[i + 1:])
        L.score = float((c_rest - cost) / max(c_rest, 1e-12))
    run.lights, run.cost, run.trace = lights, cost, fit.trace
    run.fit = room_fit(prob, lights)          # relative RMS, share within 20 % (no render)


class _RoomFit:
    """The refinement steps of one room; they share its problem, optimiser and trace.

    Each step takes and returns ``(lights, cost)``: a list of :class:`Light` and the
    refinement cost (:meth:`RefineProblem.cost`, dimensionless).
    """

    def __init__(self, run, s):
        self.run, self.s, self.prob = run, s, run.problem
        self.opt = (self.prob.levenberg_marquardt if s.optimiser == "lm"
                    else self.prob.evolution_strategy)
        self.trace = []

    def _greedy(self, cands, **kwargs):
        if self.prob.free_flux:
            # one luminaire of two's summed flux between them explains all but a small
            # part of their light: the gain that tells two apart is small in absolute
            # terms, so only the relative gain (min_gain) and a lower floor apply
            kwargs.setdefault("min_gain_total", FREE_FLUX_MIN_GAIN_TOTAL)
        return greedy_select(self.prob, cands, min_gain=self.s.min_gain,
                             optimiser=self.s.optimiser, **kwargs)

    def select(self, cands, progress=None, deadline=None):
        """Greedy selection from the peak candidates, swaps when the fit is not near-exact,
        then each luminaire's own interreflection (:meth:`settle`)."""
        prob, s = self.prob, self.s
        lights, cost, self.trace = self._greedy(cands, progress=progress, deadline=deadline)
        cost0 = prob.cost([])
        if lights and cost > 1e-3 * cost0:
            # not the near-exact fit a set of the right luminaires gives: try swaps
            lights, cost, nswap = swap_search(prob, lights, cands, min_gain=s.min_gain,
                                              optimiser=s.optimiser)
            self.trace.append({"swaps": nswap, "cost_after": cost})
            if nswap:
                # swapped luminaires may have made others redundant (or two may coincide)
                lights, cost, t2 = self._greedy([], initial=lights)
                self.trace += t2
        lights, cost = self.tidy(lights, cost)
        # each luminaire's own interreflected light from the radiosity model replaces its
        # estimate; refit, look for missing/surplus luminaires, until nothing moves
        return self.settle(lights, cost, cands)

    def tidy(self, lights, cost):
        """Snap mid-air luminaires to surfaces, prefer mounted ones, refit if any moved."""
        lights = _snap_to_surfaces(lights, self.run.canvas, self.run.scene)
        if any(L.kind == "free" for L in lights):
            lights = _prefer_mounted(self.prob, lights, self.run.canvas, self.s.optimiser)
            lights, cost = self.opt(lights)
        return lights, cost

    def converge(self, lights, cost, rounds=8):
        """Refit until every luminaire's interreflection was computed where it now is."""
        prob = self.prob
        for _round in range(rounds):
            lights, changed = prob.refresh_indirect(lights, moved=0.005)
            if not changed:
                return lights, cost
            lights, cost = self.opt(lights)
        # out of rounds: make the indirect light exact for the final positions anyway
        lights, _ = prob.refresh_indirect(lights, moved=0.0)
        return lights, prob.cost(lights)

    def settle(self, lights, cost, cands):
        """Exact interreflection for the luminaires, with re-selection from ``cands``."""
        for _round in range(2):
            lights, changed = self.prob.refresh_indirect(lights, moved=0.005)
            if not changed:
                break
            lights, cost = self.opt(lights)
            lights, cost, t2 = self._greedy(cands, initial=lights)
            self.trace += t2
            lights, cost = self.tidy(lights, cost)
        return self.converge(lights, cost)

    def overlap(self, lights, cost, cands, allow_votes):
        """Candidates from votes as if 2, 3 ... luminaires shared each point's light; a
        fresh selection over all candidates, kept if better."""
        run, s = self.run, self.s
        extra = []
        for share in range(2, s.overlap_levels + 1):
            if share not in run.extra_votes:
                if not allow_votes:
                    continue   # post-processing again never votes again
                run.extra_votes[share] = run.vote_fn(share)
            pk, _ = find_peaks(run.canvas, run.extra_votes[share], threshold=s.threshold,
                               neighbourhood=s.neighbourhood_m, max_peaks=s.max_candidates)
            extra += pk
        extra.sort(key=lambda p: -p.score)
        more = [_light_from_peak(p, run.canvas) for p in extra]
        # a fresh selection over all candidates (the first may be a local optimum that
        # adding luminaires cannot leave)
        return self._reselect(lights, cost, more, cands, "overlap_votes",
                              patience=2 * s.overlap_levels + 10)

    def _reselect(self, lights, cost, more, cands, what, **greedy):
        """A selection over ``more + cands`` (``greedy``: its options), tidied and settled;
        the better of it and (``lights``, ``cost``), traced under ``what``."""
        alt, c_alt, t2 = self._greedy(more + cands, **greedy)
        alt, c_alt = self.tidy(alt, c_alt)
        alt, c_alt = self.settle(alt, c_alt, more + cands)
        self.trace += [{what: len(more), "cost_before": cost, "cost_after": c_alt}] + t2
        if c_alt < cost:
            return alt, c_alt
        return lights, cost

    def residual(self, lights, cost, cands, significant=0.2):
        """Free-flux ladder votes with each point's light that ``lights`` do not explain
        (where that is more than ``significant`` of its target); their peaks join the
        candidates of a selection that starts from ``lights``; kept if better."""
        run, s, prob = self.run, self.s, self.prob
        pts = run.points
        rest = pts.lux - prob.fixed_light(lights)
        lux = np.where((pts.lux > 0) & (rest > significant * pts.lux), rest, 0.0)
        if not np.any(lux > 0):
            return lights, cost
        ladder = {f: run.vote_fn(f / run.flux, lux=lux) for f in run.ladder_votes}
        more = [_light_from_peak(p, run.canvas, run.flux)
                for p in _ladder_peaks(run, s, ladder)]
        return self._reselect(lights, cost, more, cands, "residual_votes", initial=lights)

    def grid(self, lights, cost, cands, flux):
        """Regular ceiling arrangements of n luminaires of ``flux`` lm as seeds; the best
        refined arrangement (with vote candidates added) is kept if better."""
        prob = self.prob
        scanned = []
        for n in _seed_counts(self.run, flux):
            seeds = _grid_seeds(self.run.canvas, n)
            if not seeds:
                continue
            if self.run.free_flux:
                # start from the lumen-method share of one of n luminaires
                for L in seeds:
                    L.flux_scale = float(np.clip(_flux_need(self.run) / (n * flux),
                                                 np.exp(-LOG_SCALE_LIMIT),
                                                 np.exp(LOG_SCALE_LIMIT)))
            seeds = [prob.with_indirect(L) for L in seeds]
            got, c = self.opt(seeds)
            self.trace.append({"grid_seed": n, "cost_after": c})
            scanned.append((c, n, got))
            if c > 1.5 * min(x[0] for x in scanned):
                break   # past the best count
        best = None
        # the scan used estimated interreflection: settle the three best counts exactly
        for c, n, got in sorted(scanned, key=lambda x: x[0])[:3]:
            got, c = self.converge(got, c)
            self.trace.append({"grid_seed_exact": n, "cost_after": c})
            if best is None or c < best[1]:
                best = (got, c)
        if best is None:
            return lights, cost
        # no pruning of the best arrangement: for evenly spread light every luminaire of
        # it does its share; the same with vote candidates added / surplus ones pruned
        alt, c_alt = best
        alt2, c_alt2 = self.settle(alt, c_alt, cands)
        if c_alt2 < c_alt:
            alt, c_alt = alt2, c_alt2
        if c_alt < cost:
            return alt, c_alt
        return lights, cost

    def seeded(self, lights, cost, cands, seeds):
        """Start from given luminaires (:class:`Luminaire`, in the room's frame) as well:
        snapped to the room's surfaces (pendants stay in mid-air; others off every
        surface are dropped), refined, pruned or added to from ``cands``, settled; kept
        if better than (``lights``, ``cost``)."""
        start = []
        for lum in seeds:
            n = np.asarray(lum.normal, dtype=np.float64)
            L = Light(kind="free", position=np.asarray(lum.position, np.float64).copy(),
                      normal=n / np.linalg.norm(n), map_index=-1,
                      flux_scale=float(lum.flux_lm) / self.run.flux if self.run.flux else 1.0)
            L = _snap_to_surfaces([L], self.run.canvas, self.run.scene)[0]
            if L.kind == "surface" or (getattr(lum, "extra", None) or {}).get("mount") == "pendant":
                start.append(self.prob.with_indirect(L))
        if not start:
            return lights, cost
        got, c = self.opt(start)
        alt, c_alt, t2 = self._greedy(cands, initial=got)
        alt, c_alt = self.tidy(alt, c_alt)
        alt, c_alt = self.settle(alt, c_alt, cands)
        self.trace += [{"seeded": len(start), "of": len(seeds), "cost_before": cost,
                        "cost_after": c_alt}] + t2
        if c_alt < cost:
            return alt, c_alt
        return lights, cost

    def spread(self, lights, cost):
        """Luminaires crowded in pairs moved apart where that costs the fit (almost)
        nothing: requirements (500 lx here, 300 lx beyond an open border) leave a flat
        cost on which the refinement can end with pairs half a metre apart, which read
        as doubled fixtures. Where two luminaires facing the same way are closer than
        :data:`SPREAD_TRIGGER` of the lumen-method spacing (:func:`_lumen_spacing`), the
        arrangement is refitted with the separation term reaching 1, 0.75 and 0.5
        spacings in turn; the first refit whose data cost (without the separation term)
        is within :data:`SPREAD_TOLERANCE` of the current one is kept. Not for a fit
        within :data:`NEAR_EXACT_FIT` (mean absolute log deviation): targets that a set of
        luminaires meets (nearly) exactly keep their answer.

        Measured on FZK-Haus' Kueche + Wohnen zone (1500 lm, 500 / 300 lx): pairs
        0.50 and 0.57 m apart; apart to 0.70 m for +0.5 % data cost, to 1.00 m for +2 %.
        """
        run, prob = self.run, self.prob
        if run.free_flux or len(lights) < 2 or fit_quality(prob, lights) <= NEAR_EXACT_FIT:
            return lights, cost       # a near-exact fit: its pairs are real
        gap = _closest_pair(lights)
        spacing = _lumen_spacing(run)
        if not (gap < SPREAD_TRIGGER * spacing):
            return lights, cost
        base = cost - prob.separation_cost(lights)
        keep = prob.separation_m
        for frac in (1.0, 0.75, 0.5):
            d0 = frac * spacing
            if d0 <= gap:
                break
            prob.separation_m = d0
            try:
                got, c = self.opt(lights)
                got, c = self.converge(got, c)
                data = c - prob.separation_cost(got)
            finally:
                prob.separation_m = keep
            self.trace.append({"spread_m": round(d0, 3), "closest_before": round(gap, 3),
                               "closest_after": round(_closest_pair(got), 3),
                               "data_cost_before": base, "data_cost_after": data})
            if data <= (1.0 + SPREAD_TOLERANCE) * base:
                return got, prob.cost(got)
        return lights, cost


#: :meth:`_RoomFit.spread`: pairs closer than this fraction of the lumen-method spacing
#: are looked at; a spread arrangement may cost this much more (relative data cost)
SPREAD_TRIGGER = 0.5
SPREAD_TOLERANCE = 0.03
#: a fit closer than this (mean absolute log deviation, :func:`fit_quality`) to its
#: targets is taken as exact: rendered targets of real luminaires (bench_random: at most
#: 0.013 in direct light; with interreflection 14 of 20 scenes below 0.003 and 6 above
#: 0.02, as many as it gets wrong), not requirements (FZK-Haus' Kueche + Wohnen zone: 0.060)
NEAR_EXACT_FIT = 0.02


def _closest_pair(lights):
    """Smallest distance (m) between two luminaires facing the same way (inf if none)."""
    best = np.inf
    for i in range(len(lights)):
        for j in range(i + 1, len(lights)):
            if lights[i].normal @ lights[j].normal >= 0.5:
                best = min(best, float(np.linalg.norm(lights[i].position
                                                      - lights[j].position)))
    return best


def _lumen_spacing(run):
    """The spacing (m) of a regular grid of luminaires of the room's flux that gives its
    mean positive target by the lumen method: sqrt(flux x 0.5 / E)."""
    pts = run.points
    lit = np.isfinite(pts.lux) & (pts.lux > 0)
    if not lit.any():
        return 0.0
    e = float(np.sum(pts.lux[lit] * pts.area[lit]) / np.sum(pts.area[lit]))
    return float(np.sqrt(0.5 * run.flux / e))


def _seed_counts(run, flux, most=24):
    """Luminaire counts to try as regular arrangements, around the lumen-method estimate.

    The flux the targets need, sum(E * A) over the targeted points, divided by the flux of
    one luminaire and a utilisation factor of 0.5, gives an estimate n0; counts from 1 to
    2 n0 + 2 are tried (at most ``most``).
    """
    n0 = _flux_need(run) / flux
    if run.free_flux:
        n0 = 12        # any count may do: the fit sets each luminaire's flux
    top = int(min(most, max(2, np.ceil(2 * n0 + 2))))
    return list(range(1, top + 1))


def _grid_seeds(canvas, n):
    """n luminaires in a regular grid over the room's footprint, on the ceiling above.

    The grid covers the bounding box of the footprint (cells of the room's aspect ratio);
    each grid point gets the lowest ceiling-like surface (normal pointing down) above it,
    so sloped and stepped ceilings work. Grid points outside the footprint are dropped.
    """
    g = canvas.grid
    ceil = [k for k, m in enumerate(canvas.maps) if m.kind == "surface" and m.normal[2] < -0.3]
    if g is None or not ceil:
        return []
    ii, jj = np.nonzero(g.footprint & np.isfinite(g.ceiling_z))
    if len(ii) == 0:
        return []
    x0, x1 = g.origin[0] + ii.min() * g.pixel, g.origin[0] + (ii.max() + 1) * g.pixel
    y0, y1 = g.origin[1] + jj.min() * g.pixel, g.origin[1] + (jj.max() + 1) * g.pixel
    aspect = (x1 - x0) / max(y1 - y0, 1e-9)
    nx = max(1, int(round(np.sqrt(n * aspect))))
    ny = int(np.ceil(n / nx))
    out = []
    for a in range(nx):
        for b in range(ny):
            if len(out) >= n:
                break
            x = x0 + (a + 0.5) * (x1 - x0) / nx
            y = y0 + (b + 0.5) * (y1 - y0) / ny
            best = None
            for k in ceil:
                m = canvas.maps[k]
                z = -(m.normal[0] * x + m.normal[1] * y + m.offset) / m.normal[2]
                p = np.array([x, y, z])
                if canvas.map_contains(k, p) and (best is None or z < best[1][2]):
                    best = (k, p)
            if best is None:
                continue
            k, p = best
            m = canvas.maps[k]
            out.append(Light(kind="surface", position=p, normal=m.normal.copy(), map_index=k,
                             plane=m.plane, origin=m.origin.copy(), u=m.u.copy(),
                             v=m.v.copy()))
    return out


def fit_quality(prob, lights):
    """Area-weighted mean absolute log deviation of the prediction from the targets."""
    vis = [prob.visibility(L) for L in lights]
    r, _ = prob.residuals(lights, vis)
    return float(np.sum(prob.w_area * np.abs(r)))


def _flux_need(run):
    """Lamp lumens the room's targets need by the lumen method: sum(E * A) over the targeted
    points over a utilisation factor of 0.5."""
    pts = run.points
    return float(np.sum(np.nan_to_num(pts.lux) * pts.area)) / 0.5


def _collect(rooms):
    out = []
    for run in rooms:
        for L in run.lights:
            flux = run.flux * L.flux_scale
            if run.free_flux:
                flux = float(np.round(flux, 1))
            extra, c0 = {"mount": "surface" if L.kind == "surface" else "pendant"}, None
            if L.mount is not None:
                from invrad_wb.core.inverse.aim import aim_extra
                more, c0 = aim_extra(L)
                extra.update(more)
            out.append(Luminaire(L.position, L.normal, flux, 0.0, room=int(run.room),
                                 score=round(float(L.score), 4), extra=extra, c0=c0))
    return out


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


def _checked_seeds(seeds):
    """``{room id: [Luminaire]}`` with finite positions and non-zero normals (else
    SettingsError naming the room and the seed)."""
    out = {}
    for room, lums in (seeds or {}).items():
        out[int(room)] = list(lums)
        for i, lum in enumerate(out[int(room)]):
            p = np.asarray(getattr(lum, "position", None), dtype=np.float64)
            n = np.asarray(getattr(lum, "normal", None), dtype=np.float64)
            if (p.shape != (3,) or n.shape != (3,) or not np.all(np.isfinite(p))
                    or not np.all(np.isfinite(n)) or not np.linalg.norm(n) > 0):
                raise SettingsError(f"seed {i + 1} of room {room}: a luminaire needs a"
                                    f" finite position and a non-zero normal, got"
                                    f" {getattr(lum, 'position', lum)!r}")
    return out


def _checked_settings(settings, overrides):
    """LocateSettings from None, a LocateSettings or a dict, with ``overrides``, checked."""
    if settings is None:
        settings = LocateSettings()
    elif isinstance(settings, dict):
        settings = LocateSettings.from_dict(settings)
    if overrides:
        settings = LocateSettings.from_dict({**asdict(settings), **overrides})
    return settings.check()


def check_flux(flux_lm):
    """The flux of one luminaire as a positive float, lm (else SettingsError)."""
    try:
        flux = float(flux_lm)
    except (TypeError, ValueError):
        raise SettingsError(f"flux must be a number of lumens, got {flux_lm!r}")
    if not np.isfinite(flux) or flux <= 0:
        raise SettingsError(f"flux must be a positive number of lumens, got {flux_lm!r}")
    return flux


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
        ladder = _flux_ladder(pts)
        flux = max(ladder)
    vote_fn = _vote_function(canvas, pts, ambient, occ, s, flux, backend, timings, photometry)
    if free:
        # votes as if 1/share of the light came from a luminaire of flux: one of f = share*flux
        ladder = {f: vote_fn(f / flux) for f in ladder}
        votes = max(ladder.values(), key=lambda v: float(np.max(v, initial=0.0)))
    else:
        votes = vote_fn(1)
    prob, indirect_model = _refine_problem(sub, pts, canvas, occ, s, flux, backend, has_rho,
                                           timings, photometry)
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


#: a luminaire is kept when the fluxes are free if it lowers the cost by this fraction of
#: the cost without any luminaire (and by ``min_gain`` of the current cost); greedy
#: selection's default is 0.005
FREE_FLUX_MIN_GAIN_TOTAL = 0.002
#: successive fluxes of the free-flux vote ladder differ by this factor
FLUX_LADDER_STEP = 2.0
#: the ladder spans need / 2**FLUX_LADDER_OCTAVES .. need (the room's lumen-method need)
FLUX_LADDER_OCTAVES = 6


def _flux_ladder(pts):
    """Fluxes (lm) to vote with when the flux is not given, largest first.

    The top is the lamp flux the room's targets need by the lumen method (sum(E A) / 0.5,
    one luminaire doing it all); each next one is :data:`FLUX_LADDER_STEP` smaller, down
    to 1/2**:data:`FLUX_LADDER_OCTAVES` of it. A luminaire of flux F gets sharp votes
    from the rung nearest F; the refinement then fits F itself.
    """
    need = float(np.sum(np.nan_to_num(pts.lux) * pts.area)) / 0.5
    n = int(round(FLUX_LADDER_OCTAVES * np.log(2.0) / np.log(FLUX_LADDER_STEP)))
    return [need / FLUX_LADDER_STEP ** k for k in range(n + 1)]


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


def _occluders(scene, s):
    """BVH of the faces that can occlude within the room (None: no occlusion test)."""
    if s.occlusion is False:
        return None
    faces = occluding_faces(scene) if s.occlusion == "auto" else scene.occluder_faces
    return BVH(scene.triangles[faces]) if len(faces) else None


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


def _refine_problem(scene, pts, canvas, occ, s, flux, backend, has_rho, timings,
                    photometry=None):
    """The joint refinement problem of a room's voting points and its radiosity model.

    Returns ``(RefineProblem, _Indirect or None)``.
    """
    from invrad_wb.core.forward.occlusion import segments_occluded
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

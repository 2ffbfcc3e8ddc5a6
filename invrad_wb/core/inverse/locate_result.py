"""What a locate run returns: :class:`LocateResult` (luminaires, settings, timings) and
per room a :class:`RoomRun`, which keeps what re-peaking needs and pickles without its
rebuildable parts (a room run on a worker process comes back without them)."""
from dataclasses import dataclass, field, asdict
import time

import numpy as np

from invrad_wb.core.model.luminaires import Luminaire
from invrad_wb.core.inverse.locate_settings import LocateSettings
from invrad_wb.core.inverse.locate_problem import _refine_problem, _vote_function
from invrad_wb.core.inverse.locate_fit import _postprocess


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
    #: CPU seconds of refinement after which the searches stopped on a poor fit (None: ran
    #: through; :data:`invrad_wb.constants.LOCATE_UNEXPLAINED_LIMIT_S`)
    stopped_after_s: float = None

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
                from invrad_wb.core.forward.radiosity import RadiosityModel
                RadiosityModel.forget(self.scene)
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
            has_rho, t, photometry, at_vertices=self.free_flux)
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
                           "stopped_after_s": getattr(r, "stopped_after_s", None),
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


def _collect(rooms):
    out = []
    for run in rooms:
        number = {}            # a room's flux groups numbered 1, 2, ... as they come
        for L in run.lights:
            flux = run.flux * L.flux_scale
            if run.free_flux:
                flux = float(np.round(flux, 1))
            extra, c0 = {"mount": "surface" if L.kind == "surface" else "pendant"}, None
            if run.free_flux and getattr(L, "flux_group", -1) >= 0:
                # luminaires of one kind: their fluxes fitted as one (locate_ties)
                extra["flux_group"] = number.setdefault(int(L.flux_group), len(number) + 1)
            if L.mount is not None:
                from invrad_wb.core.inverse.aim import aim_extra
                more, c0 = aim_extra(L)
                extra.update(more)
            out.append(Luminaire(L.position, L.normal, flux, 0.0, room=int(run.room),
                                 score=round(float(L.score), 4), extra=extra, c0=c0))
    return out

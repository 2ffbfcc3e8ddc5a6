"""Locate settings: what a run may be asked (:class:`LocateSettings`, checked with one
line naming the setting), the flux and the seeds a caller gives."""
from dataclasses import dataclass, asdict

import numpy as np

from invrad_wb.errors import SettingsError


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
        if self.dummy_count is not None and self.dummy_count < 0:
            raise SettingsError(f"dummy_count must be >= 0 (0: no dummy planes), got"
                                f" {self.dummy_count!r}")
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

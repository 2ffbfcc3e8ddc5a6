"""Design specifications: the architect's requirements and her luminaire catalogue.

A design spec (``DESIGN.json``) says, per room, what light is required and which luminaires
may be used; :func:`read_spec` / :func:`spec_from_dict` check it completely before any
computation and name the offending key and value in one line::

    {"maintenance_factor": 0.8,
     "catalogue": [{"name": "DL-2000", "flux_lm": 2000, "watts": 15.0, "radius_m": 0.0,
                    "dimming": [0.1, 1.0], "mounting": ["ceiling"],
                    "photometry": "dl2000.ldt"}],
     "rooms": {"0": {"work_plane": {"lux": 500, "u0": 0.6, "height_m": 0.75,
                                    "margin_m": 0.5},
                     "room_type": "office",
                     "mounting": {"type": "pendant", "height_m": 2.5},
                     "catalogue": ["DL-2000"],
                     "shade_limit_lux": 5,
                     "walls": {"lux": 75, "u0": 0.1}, "ceiling": {"lux": 50, "u0": 0.1},
                     "ugr_max": 19, "cylindrical": {"lux": 150, "u0": 0.1},
                     "background": {"lux": 100, "u0": 0.1},
                     "operating_hours": 2500}}}

The task area is the work plane less its border zone ``margin_m``, or the task areas the
work plane lists (``"task_areas": [{"name": "desks", "rect": [x0, y0, x1, y1]}, {"name":
"counter", "polygon": [[x, y], ...], "lux": 300}]``, metres in the scene's coordinates,
optional ``lux`` / ``u0`` per area; not both: :mod:`.taskareas`).

Room keys are the PLY room id (``"0"``) or the room's name in FreeCAD/IFC; ``"*"`` applies to
every room not listed. Requirements are *maintained* values (EN 12464-1): a new
installation must give ``lux / maintenance_factor`` (CIE 97 simplified: one factor for lamp
lumen depreciation, luminaire and room soiling). A room with a ``room_type`` but no
``work_plane`` takes the EN 12464-1 values of that type (:mod:`.en12464`).

The walls and the ceiling of every room are held to at least the EN 12464-1:2021 5.2.3
minimums (walls 50 lx, ceiling 30 lx, U0 0.10 each; 75 / 50 lx in offices and education);
``"walls"`` / ``"ceiling"`` may ask for more, never for less. ``"ugr_max"`` is the UGR limit
(default: the room type's). ``"cylindrical"`` (Ez where people meet and talk) is computed and
judged (:mod:`.cylindrical`). ``"background": {"lux", "u0"}`` is the background area beyond
the task area's immediate surroundings (:mod:`.background`): by default EN 12464-1:2021's
one third of the surroundings' Em with U0 0.10 wherever the task area leaves one; more
may be asked, never less; ``"background": null`` is "no limit". ``"operating_hours"`` (per
room or for the whole spec, h/a) gives the energy estimate.
A catalogue entry with ``"aimable": true`` (and ``"max_tilt_deg"``, default
:data:`DEFAULT_MAX_TILT_DEG`) is an adjustable spot: it lights painted spots as an aimed
accent (:mod:`invrad_wb.core.design.accents`) and is kept out of the general lighting.

``"design_margin"`` (a fraction, default :data:`DESIGN_MARGIN`) is kept above every mean
illuminance minimum (work plane, walls, ceiling, surroundings, Ez) when a design is dimmed:
another engine (Radiance, DIALux) models the same room a little differently (its
interreflection, its mesh), and a design dimmed to exactly 500 lx by one may be 498 lx by
the other. The verdicts are still taken on the minimums themselves.

Units: lux, lumens, watts, metres.
"""
from dataclasses import dataclass, field
import json
import math
import os
from typing import Optional

from invrad_wb.errors import SettingsError
from invrad_wb.core.geometry.polygon import drop_repeats, polygon_area, self_intersection

#: Mounting kinds a catalogue entry or a room may allow.
MOUNTINGS = ("ceiling", "pendant", "wall")
#: Light a "must stay dark" point may receive before it vetoes a candidate (lux).
DEFAULT_SHADE_LIMIT_LUX = 5.0
#: EN 12464-1 border zone of a work plane that is a whole room (metres).
DEFAULT_MARGIN_M = 0.5
#: share a dimmed design keeps above each mean illuminance minimum (``"design_margin"``):
#: the spread between two honest engines on the same room. Measured against Radiance
#: (bench/bench_design_radiance.py) once luminous openings light from their area and hide
#: the ceiling behind them: work plane, walls and surroundings within 0.1-0.4 % in four
#: rooms; Radiance's rtrace -ab 6 stops the interreflection series early (a closed box:
#: -1.9 % of it at rho 0.5, -8.4 % at rho 0.7), which 1 % covers on a work plane
DESIGN_MARGIN = 0.01
#: Largest tilt of an aimable entry that does not state its own (degrees).
DEFAULT_MAX_TILT_DEG = 60.0
#: Usual desk height (metres).
DEFAULT_WORK_PLANE_HEIGHT_M = 0.75


@dataclass
class CatalogueEntry:
    """One luminaire type of the catalogue.

    Attributes
    ----------
    name : str
    flux_lm : float, lumens at full output (the luminaire's, LOR included)
    watts : float, system power at full output
    radius_m : float, radius of a disk emitter (0: point)
    dimming : (float, float), lowest and highest output as fractions of ``flux_lm``
        ((1, 1): not dimmable). Power is taken proportional to output (LED drivers).
    mounting : tuple of str, subset of :data:`MOUNTINGS`
    photometry : str or None, path of an EULUMDAT (.ldt) or IES (.ies) file
    mount_height_m : (float, float), the mounting heights above the floor the maker
        allows (e.g. high-bays from 4 m); (0, inf) if not stated
    aimable : bool, an adjustable spot (gimbal, track): it lights painted spots as an
        aimed accent (:mod:`invrad_wb.core.design.accents`), not the work plane
    max_tilt_deg : float, the largest tilt off its mounting surface's normal (aimable)
    orientation : None, 'along' or 'across': set by the design on a copy of an entry whose
        photometry is not the same in every C plane (C0 laid along the room's longer side
        or across it, both tried); None: the photometric frame of the mount normal
    """

    name: str
    flux_lm: float
    watts: float
    radius_m: float = 0.0
    dimming: tuple = (1.0, 1.0)
    mounting: tuple = ("ceiling", "pendant")
    photometry: Optional[str] = None
    mount_height_m: tuple = (0.0, math.inf)
    aimable: bool = False
    max_tilt_deg: float = 0.0
    orientation: Optional[str] = None

    @property
    def key(self):
        """The entry as the search tells it apart (its name, and how it is turned)."""
        return self.name if self.orientation is None else f"{self.name} (C0 {self.orientation})"

    @property
    def efficacy(self):
        """Luminous efficacy, lm/W."""
        return self.flux_lm / self.watts

    @property
    def dimmable(self):
        return self.dimming[0] < 1.0

    def to_dict(self):
        d = {"name": self.name, "flux_lm": self.flux_lm, "watts": self.watts,
             "radius_m": self.radius_m, "dimming": list(self.dimming),
             "mounting": list(self.mounting)}
        if self.photometry:
            d["photometry"] = self.photometry
        if self.mount_height_m != (0.0, math.inf):
            # as the spec writes it: null is "no upper limit" (JSON has no infinity)
            d["mount_height_m"] = [h if math.isfinite(h) else None
                                   for h in self.mount_height_m]
        if self.aimable:
            d.update(aimable=True, max_tilt_deg=self.max_tilt_deg)
        return d


#: the surface grid of an explicit task area is named this prefix and its name
#: (:mod:`.taskareas`); like the surroundings and the background it lies on the work plane
TASK_PART = "task area: "


def part_name(name):
    """The surface-grid name of the task area ``name``."""
    return TASK_PART + name


@dataclass(frozen=True)
class TaskArea:
    """One task area: ``polygon`` ((k, 2) tuple of (x, y), counter-clockwise), its
    requirement (None: the work plane's)."""

    name: str
    polygon: tuple
    lux: float = None
    u0: float = None
    rect: bool = False

    @property
    def part(self):
        return part_name(self.name)

    @property
    def area_m2(self):
        return abs(polygon_area(self.polygon))

    def to_dict(self):
        d = {"name": self.name}
        if self.rect:
            (x0, y0), (x1, y1) = self.polygon[0], self.polygon[2]
            d["rect"] = [x0, y0, x1, y1]
        else:
            d["polygon"] = [list(p) for p in self.polygon]
        if self.lux is not None:
            d["lux"] = self.lux
        if self.u0 is not None:
            d["u0"] = self.u0
        return d


@dataclass
class WorkPlaneRequirement:
    """Maintained illuminance ``lux`` with uniformity ``u0`` (Emin/Em) on a work plane."""

    lux: float
    u0: float = 0.0
    height_m: float = DEFAULT_WORK_PLANE_HEIGHT_M
    margin_m: float = DEFAULT_MARGIN_M
    source: str = "spec"
    #: the task areas given explicitly (:class:`~.taskareas.TaskArea`), or () : the task
    #: area is the work plane less ``margin_m``
    task_areas: tuple = ()

    def to_dict(self):
        d = {"lux": self.lux, "u0": self.u0, "height_m": self.height_m,
             "margin_m": self.margin_m, "source": self.source}
        if self.task_areas:
            del d["margin_m"]        # not used: the task areas are given
            d["task_areas"] = [a.to_dict() for a in self.task_areas]
        return d


@dataclass
class SurfaceRequirement:
    """Maintained mean illuminance ``lux`` with uniformity ``u0`` on the walls or the
    ceiling of a room (EN 12464-1:2021 5.2.3); ``source`` says where the values come from."""

    lux: float
    u0: float = 0.10
    source: str = "spec"

    def to_dict(self):
        return {"lux": self.lux, "u0": self.u0, "source": self.source}


def surface_requirements(given, room_type=None):
    """Effective walls and ceiling requirements of a room: what the spec gives (``given``:
    {'walls': (lux, u0) or None, 'ceiling': ...}), never below the EN 12464-1:2021
    minimums of its room type, which apply to every enclosed space."""
    from invrad_wb.core.design import en12464
    mins = en12464.surface_minimums(room_type)
    out = {}
    for part in ("walls", "ceiling"):
        lo_lux, lo_u0 = mins[part]
        what = f"{en12464.SURFACE_REFERENCE}" + (f" ({room_type})" if room_type else "")
        g = given.get(part)
        if g is None:
            out[part] = SurfaceRequirement(lo_lux, lo_u0, f"{what} minimum")
            continue
        lux, u0 = g
        raised = lux < lo_lux or u0 < lo_u0
        out[part] = SurfaceRequirement(
            max(lux, lo_lux), max(u0, lo_u0),
            f"spec, raised to the {what} minimum" if raised else "spec")
    return out


@dataclass
class Mounting:
    """Where luminaires may go: ``ceiling`` (recessed/surface, facing into the room),
    ``pendant`` (hanging, facing down, ``height_m`` above the floor) or ``wall``."""

    kind: str = "ceiling"
    height_m: Optional[float] = None


@dataclass
class RoomSpec:
    """Requirements of one room (or of every unlisted room, key ``"*"``)."""

    key: str
    work_plane: Optional[WorkPlaneRequirement] = None
    room_type: Optional[str] = None
    mounting: Mounting = field(default_factory=Mounting)
    catalogue: Optional[tuple] = None
    shade_limit_lux: float = DEFAULT_SHADE_LIMIT_LUX
    ugr_max: Optional[float] = None
    #: {'walls': SurfaceRequirement, 'ceiling': SurfaceRequirement}
    surfaces: dict = field(default_factory=lambda: surface_requirements({}))
    #: cylindrical illuminance Ez asked for (lux, u0, height_m) or None (judged:
    #: :mod:`.cylindrical`)
    cylindrical: Optional[dict] = None
    #: annual operating hours (for the energy estimate) or None
    operating_hours: Optional[float] = None
    #: the background area's requirement as the spec gives it (:mod:`.background`):
    #: None: the EN 12464-1:2021 default (1/3 of the surroundings' Em, U0 0.10); False:
    #: ``null`` in the spec, no limit; else (lux or None, u0)
    background: object = None


@dataclass
class DesignSpec:
    maintenance_factor: float
    catalogue: list
    rooms: dict
    source: str = "design spec"
    #: share kept above each mean illuminance minimum when dimming (:data:`DESIGN_MARGIN`)
    design_margin: float = None

    def __post_init__(self):
        if self.design_margin is None:
            self.design_margin = DESIGN_MARGIN

    def room_spec(self, room_id, name=None):
        """The :class:`RoomSpec` of a room by id or name; ``"*"``; else None."""
        for key in (str(room_id), name):
            if key is not None and key in self.rooms:
                return self.rooms[key]
        return self.rooms.get("*")

    def entries_for(self, room_spec, mount_height_m=None):
        """Catalogue entries allowed in a room, for its mounting and (if given) a mounting
        height above the floor (metres)."""
        names = room_spec.catalogue
        kind = room_spec.mounting.kind
        h = mount_height_m
        return [e for e in self.catalogue
                if (names is None or e.name in names) and kind in e.mounting
                and (h is None or e.mount_height_m[0] <= h <= e.mount_height_m[1])]


# --------------------------------------------------------------------------- parsing
class _Where:
    """Builds the 'file: key.path' prefix of error messages."""

    def __init__(self, source, path=()):
        self.source, self.path = source, tuple(path)

    def __truediv__(self, key):
        return _Where(self.source, self.path + (str(key),))

    def error(self, message):
        where = ".".join(self.path)
        return SettingsError(f"{self.source}: {where}: {message}" if where
                             else f"{self.source}: {message}")


def _number(value, where, unit, lo=None, hi=None, lo_open=False, allow_none=False):
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise where.error(f"{value!r} is not a number of {unit}")
    x = float(value)
    if not math.isfinite(x):
        raise where.error(f"{x} {unit} is not finite")
    if lo is not None and (x <= lo if lo_open else x < lo):
        raise where.error(f"{x:g} {unit} must be {'>' if lo_open else '>='} {lo:g}")
    if hi is not None and x > hi:
        raise where.error(f"{x:g} {unit} must be <= {hi:g}")
    return x


def _object(value, where, keys):
    if not isinstance(value, dict):
        raise where.error(f"expected an object, got {type(value).__name__}")
    unknown = sorted(set(value) - set(keys))
    if unknown:
        raise where.error(f"unknown key {unknown[0]!r} (known: {', '.join(keys)})")
    return value


def _entry(d, where, base_dir):
    d = _object(d, where, ("name", "flux_lm", "watts", "radius_m", "dimming", "mounting",
                           "photometry", "mount_height_m", "description", "aimable",
                           "max_tilt_deg"))
    name = d.get("name")
    if not isinstance(name, str) or not name.strip():
        raise (where / "name").error(f"{name!r}: every catalogue entry needs a name")
    w = where / name
    flux = _number(d.get("flux_lm"), w / "flux_lm", "lm", lo=0, lo_open=True)
    watts = _number(d.get("watts"), w / "watts", "W", lo=0, lo_open=True)
    if flux / watts > 683.0:
        raise (w / "watts").error(f"{flux:g} lm from {watts:g} W is {flux / watts:.0f} lm/W,"
                                  " above the 683 lm/W that physics allows")
    radius = _number(d.get("radius_m", 0.0), w / "radius_m", "m", lo=0, hi=5.0)
    dim = d.get("dimming", [1.0, 1.0])
    if not (isinstance(dim, (list, tuple)) and len(dim) == 2):
        raise (w / "dimming").error(f"{dim!r}: give [lowest, highest] output fractions")
    lo = _number(dim[0], w / "dimming", "(fraction)", lo=0, lo_open=True, hi=1.0)
    hi = _number(dim[1], w / "dimming", "(fraction)", lo=lo, hi=1.0)
    if hi != 1.0:
        raise (w / "dimming").error(f"highest output {hi:g} must be 1 (flux_lm is the"
                                    " full output)")
    mounting = d.get("mounting", ["ceiling", "pendant"])
    if isinstance(mounting, str):
        mounting = [mounting]
    bad = [m for m in mounting if m not in MOUNTINGS]
    if bad or not mounting:
        raise (w / "mounting").error(f"{bad[0] if bad else mounting!r}: mounting must be"
                                     f" some of {', '.join(MOUNTINGS)}")
    phot = d.get("photometry")
    if phot is not None:
        if not isinstance(phot, str):
            raise (w / "photometry").error(f"{phot!r} is not a file name")
        phot = phot if os.path.isabs(phot) else os.path.join(base_dir, phot)
        if not os.path.isfile(phot):
            raise (w / "photometry").error(f"no such file: {phot}")
        from invrad_wb.core.model.photometry import read_photometry
        from invrad_wb.errors import LuminaireError
        try:
            read_photometry(phot)      # parsed now: a bad file fails before any work
        except LuminaireError as exc:
            raise (w / "photometry").error(str(exc))
    mh = d.get("mount_height_m", [0.0, None])
    if not (isinstance(mh, (list, tuple)) and len(mh) == 2):
        raise (w / "mount_height_m").error(f"{mh!r}: give [lowest, highest] metres")
    h0 = _number(mh[0], w / "mount_height_m", "m", lo=0)
    h1 = _number(mh[1], w / "mount_height_m", "m", lo=h0, allow_none=True)
    aimable = d.get("aimable", False)
    if not isinstance(aimable, bool):
        raise (w / "aimable").error(f"{aimable!r}: give true or false")
    if "max_tilt_deg" in d and not aimable:
        raise (w / "max_tilt_deg").error("a largest tilt needs \"aimable\": true")
    tilt = (_number(d.get("max_tilt_deg", DEFAULT_MAX_TILT_DEG), w / "max_tilt_deg",
                    "degrees", lo=0, hi=89.0) if aimable else 0.0)
    return CatalogueEntry(name.strip(), flux, watts, radius, (lo, hi), tuple(mounting), phot,
                          (h0, math.inf if h1 is None else h1), aimable, tilt)


def _work_plane(d, where, source="spec"):
    d = _object(d, where, ("lux", "u0", "height_m", "margin_m", "task_areas"))
    lux = _number(d.get("lux"), where / "lux", "lx", lo=0, lo_open=True)
    u0 = _number(d.get("u0", 0.0), where / "u0", "(Emin/Em)", lo=0, hi=1.0)
    h = _number(d.get("height_m", DEFAULT_WORK_PLANE_HEIGHT_M), where / "height_m", "m",
                lo=0, hi=20.0)
    margin = _number(d.get("margin_m", DEFAULT_MARGIN_M), where / "margin_m", "m", lo=0,
                     hi=10.0)
    areas = ()
    if d.get("task_areas") is not None:
        if "margin_m" in d:
            raise (where / "margin_m").error(
                "give either margin_m (the task area is the room less a border zone) or"
                " task_areas (the desks, tables, counters), not both")
        areas = _task_areas(d["task_areas"], where / "task_areas")
    return WorkPlaneRequirement(lux, u0, h, margin, source, areas)


def _point(p, where):
    if not (isinstance(p, (list, tuple)) and len(p) == 2):
        raise where.error(f"{p!r}: give a point as [x, y] (metres)")
    return (_number(p[0], where, "m"), _number(p[1], where, "m"))


#: the least area of a task area (a rectangle or a polygon), m^2
MIN_TASK_AREA_M2 = 1e-6


def _task_areas(value, where):
    """The work plane's ``"task_areas"``: a non-empty list of
    ``{"name", "rect": [x0, y0, x1, y1]}`` or ``{"name", "polygon": [[x, y], ...]}``
    (metres, the scene's coordinates; optional ``"lux"``, ``"u0"``: else the work
    plane's); polygons simple, of non-zero area, turned counter-clockwise."""
    if not isinstance(value, list) or not value:
        raise where.error(f"{value!r}: give a non-empty list of task areas, e.g."
                          ' [{"name": "desks", "rect": [x0, y0, x1, y1]}]')
    out, names = [], set()
    for i, d in enumerate(value):
        d = _object(d, where / i, ("name", "rect", "polygon", "lux", "u0"))
        name = d.get("name", f"task area {i + 1}")
        if not isinstance(name, str) or not name.strip():
            raise (where / i / "name").error(f"{name!r}: a task area's name is a text")
        name = name.strip()
        # messages name the area by its key, or by its index where a "." in the name
        # would read as a deeper key (FreeCAD labels such as "Desk 1.2" are names too)
        w = where / (i if "." in name else name)
        if name in names:
            raise w.error(f"the name {name!r} is used twice")
        names.add(name)
        if ("rect" in d) == ("polygon" in d):
            raise w.error("give either \"rect\": [x0, y0, x1, y1] or \"polygon\":"
                          " [[x, y], ...] (metres)")
        if "rect" in d:
            r = d["rect"]
            if not (isinstance(r, (list, tuple)) and len(r) == 4):
                raise (w / "rect").error(f"{r!r}: give [x0, y0, x1, y1] (metres)")
            x0, y0, x1, y1 = (_number(x, w / "rect", "m") for x in r)
            if x1 <= x0 or y1 <= y0:
                raise (w / "rect").error(f"{list(r)!r} has no area: x1 must be > x0 and"
                                         " y1 > y0")
            if (x1 - x0) * (y1 - y0) < MIN_TASK_AREA_M2:
                raise (w / "rect").error(f"{list(r)!r} has zero area (under"
                                         f" {MIN_TASK_AREA_M2:g} m2)")
            poly, rect = ((x0, y0), (x1, y0), (x1, y1), (x0, y1)), True
        else:
            pl = d["polygon"]
            if not isinstance(pl, (list, tuple)) or len(pl) < 3:
                raise (w / "polygon").error(f"{pl!r}: a polygon needs at least 3 points"
                                            " [[x, y], ...]")
            # a corner given twice, the first point repeated to close it
            poly, rect = drop_repeats(_point(p, w / "polygon") for p in pl), False
            if len(poly) < 3:
                raise (w / "polygon").error(f"{pl!r}: a polygon needs at least 3 distinct"
                                            " points [[x, y], ...]")
            cut = self_intersection(poly)
            if cut is not None:
                i0, j0 = cut
                raise (w / "polygon").error(
                    f"edges {i0 + 1} and {j0 + 1} cross: the polygon intersects itself"
                    " (give its corners in order around it)")
            a = polygon_area(poly)
            if abs(a) < MIN_TASK_AREA_M2:
                raise (w / "polygon").error(f"{[list(p) for p in poly]!r} has zero area"
                                            f" (under {MIN_TASK_AREA_M2:g} m2)")
            if a < 0:
                poly = poly[::-1]
        lux = _number(d.get("lux"), w / "lux", "lx", lo=0, lo_open=True, allow_none=True)
        u0 = _number(d.get("u0"), w / "u0", "(Emin/Em)", lo=0, hi=1.0, allow_none=True)
        out.append(TaskArea(name, poly, lux, u0, rect))
    return tuple(out)


def task_areas_from(value, source, path=()):
    """The public reader of a ``"task_areas"`` list for callers outside the spec (the
    workbench's targets file): checked exactly as :func:`spec_from_dict` checks it, errors
    prefixed ``source: path...`` (:class:`~invrad_wb.errors.SettingsError`)."""
    return _task_areas(value, _Where(source, path))


def _mounting(d, where):
    if isinstance(d, str):
        d = {"type": d}
    d = _object(d, where, ("type", "height_m"))
    kind = d.get("type", "ceiling")
    if kind not in MOUNTINGS:
        raise (where / "type").error(f"{kind!r}: mounting must be one of"
                                     f" {', '.join(MOUNTINGS)}")
    h = _number(d.get("height_m"), where / "height_m", "m", lo=0, lo_open=True, hi=50.0,
                allow_none=True)
    if kind in ("pendant", "wall") and h is None:
        raise (where / "height_m").error(f"a {kind} mounting needs its height above the"
                                         " floor")
    return Mounting(kind, h)


def _room(key, d, where, catalogue_names, default_hours=None):
    from invrad_wb.core.design import en12464
    d = _object(d, where, ("work_plane", "room_type", "mounting", "catalogue",
                           "shade_limit_lux", "ugr_max", "name", "walls", "ceiling",
                           "cylindrical", "operating_hours", "background"))
    rtype = d.get("room_type")
    wp = d.get("work_plane")
    ugr_max = _number(d.get("ugr_max"), where / "ugr_max", "(UGR)", lo=5, hi=40,
                      allow_none=True)
    if rtype is not None:
        if not isinstance(rtype, str) or en12464.lookup(rtype) is None:
            raise (where / "room_type").error(
                f"{rtype!r} is not a known room type (known: {', '.join(en12464.names())})")
    if wp is not None and rtype is not None and isinstance(wp, dict) and "lux" not in wp:
        # the room type's Em and U0 on a work plane of the given height/margin
        req = en12464.lookup(rtype)
        work_plane = _work_plane({"lux": req.em_lux, "u0": req.u0, **wp}, where / "work_plane",
                                 source=f"EN 12464-1 {req.reference}: {req.task}")
    elif wp is not None:
        work_plane = _work_plane(wp, where / "work_plane")
    elif rtype is not None:
        req = en12464.lookup(rtype)
        work_plane = WorkPlaneRequirement(req.em_lux, req.u0,
                                          source=f"EN 12464-1 {req.reference}: {req.task}")
    else:
        work_plane = None
    if rtype is not None and "ugr_max" not in d:
        # the type's limit, whether its work plane is the type's or given (a level of its
        # own does not make the room another type); "ugr_max": null is "no limit"
        ugr_max = en12464.lookup(rtype).ugr_limit
    cat = d.get("catalogue")
    if cat is not None:
        if not isinstance(cat, list) or not cat:
            raise (where / "catalogue").error("give a non-empty list of catalogue names")
        unknown = [c for c in cat if c not in catalogue_names]
        if unknown:
            raise (where / "catalogue").error(f"{unknown[0]!r} is not in the catalogue"
                                              f" ({', '.join(catalogue_names)})")
        cat = tuple(cat)
    shade = _number(d.get("shade_limit_lux", DEFAULT_SHADE_LIMIT_LUX),
                    where / "shade_limit_lux", "lx", lo=0)
    given = {}
    for part in ("walls", "ceiling"):
        if d.get(part) is not None:
            sd = _object(d[part], where / part, ("lux", "u0"))
            given[part] = (_number(sd.get("lux"), where / part / "lux", "lx", lo=0),
                           _number(sd.get("u0", 0.10), where / part / "u0", "(Emin/Em)",
                                   lo=0, hi=1.0))
    cyl = d.get("cylindrical")
    if cyl is not None:
        cd = _object(cyl, where / "cylindrical", ("lux", "u0", "height_m"))
        cyl = {"lux": _number(cd.get("lux"), where / "cylindrical" / "lux", "lx", lo=0),
               "u0": _number(cd.get("u0", 0.10), where / "cylindrical" / "u0", "(Emin/Em)",
                             lo=0, hi=1.0),
               "height_m": _number(cd.get("height_m", 1.2), where / "cylindrical" / "height_m",
                                   "m", lo=0, hi=20.0)}
    elif rtype is not None and en12464.lookup(rtype).cylindrical_lux:
        cyl = {"lux": en12464.lookup(rtype).cylindrical_lux, "u0": 0.10, "height_m": 1.2}
    hours = _number(d.get("operating_hours", default_hours), where / "operating_hours",
                    "h/a", lo=0, hi=8760.0, allow_none=True)
    background = None
    if "background" in d:
        if d["background"] is None:
            background = False          # null: no limit
        else:
            bd = _object(d["background"], where / "background", ("lux", "u0"))
            background = (_number(bd.get("lux"), where / "background" / "lux", "lx", lo=0,
                                  allow_none=True),
                          _number(bd.get("u0", 0.10), where / "background" / "u0",
                                  "(Emin/Em)", lo=0, hi=1.0))
    return RoomSpec(key, work_plane, rtype, _mounting(d.get("mounting", "ceiling"),
                                                      where / "mounting"),
                    cat, shade, ugr_max, surface_requirements(given, rtype), cyl, hours,
                    background)


def spec_from_dict(d, source="design spec", base_dir="."):
    """Check a design spec and build a :class:`DesignSpec` (raises SettingsError)."""
    where = _Where(source)
    d = _object(d, where, ("maintenance_factor", "catalogue", "rooms", "project",
                           "description", "operating_hours", "design_margin"))
    margin = _number(d.get("design_margin", DESIGN_MARGIN), where / "design_margin",
                     "(fraction)", lo=0, hi=0.2)
    hours = _number(d.get("operating_hours"), where / "operating_hours", "h/a", lo=0,
                    hi=8760.0, allow_none=True)
    mf = _number(d.get("maintenance_factor", 0.8), where / "maintenance_factor",
                 "(fraction)", lo=0, lo_open=True, hi=1.0)
    cat = d.get("catalogue")
    if not isinstance(cat, list) or not cat:
        raise (where / "catalogue").error("the catalogue is empty: list at least one"
                                          " luminaire (name, flux_lm, watts)")
    catalogue = [_entry(e, where / "catalogue" / i, base_dir) for i, e in enumerate(cat)]
    names = [e.name for e in catalogue]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise (where / "catalogue").error(f"name {sorted(dup)[0]!r} is used twice")
    rooms_d = d.get("rooms")
    if not isinstance(rooms_d, dict) or not rooms_d:
        raise (where / "rooms").error("no rooms: give requirements per room id or name"
                                      " (or '*' for every room)")
    rooms = {str(k): _room(str(k), v, where / "rooms" / k, names, hours)
             for k, v in rooms_d.items()}
    spec = DesignSpec(mf, catalogue, rooms, source, margin)
    for key, rs in rooms.items():
        if not spec.entries_for(rs):
            raise (where / "rooms" / key).error(
                f"no catalogue entry allows {rs.mounting.kind} mounting"
                + (f" among {', '.join(rs.catalogue)}" if rs.catalogue else ""))
    return spec


def read_spec(path):
    """Read and check ``DESIGN.json`` (raises SettingsError naming the file and key)."""
    try:
        with open(path, "rb") as fh:
            data = json.loads(fh.read().decode("utf-8"))
    except FileNotFoundError:
        raise SettingsError(f"{path}: no such design spec file")
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise SettingsError(f"{path}: not a readable JSON design spec ({e})")
    return spec_from_dict(data, source=os.fspath(path),
                          base_dir=os.path.dirname(os.path.abspath(path)))

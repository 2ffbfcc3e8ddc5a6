"""EN 12464-1 requirements of common room types, and its calculation grid.

Source: EN 12464-1:2021 "Light and lighting - Lighting of work places - Part 1: Indoor work
places", clause 5 (schedule of lighting requirements: maintained illuminance Em, uniformity
U0 = Emin/Em, unified glare rating limit UGR_L, colour rendering Ra) and clause 4.4/Annex on
the calculation grid; clause 5.2.3 (walls and ceiling of every enclosed space: a maintained
mean illuminance of at least 50 lx on the walls and 30 lx on the ceiling, each with
U0 >= 0.10; at least 75 lx and 50 lx in offices, education and health care premises). The
table below holds the values commonly quoted for the room types
architects ask for most; it is a convenience, not a substitute for the standard: a
requirement stated in the design spec always wins. Residential rooms are not covered by
EN 12464-1; give their requirement explicitly.
"""
from dataclasses import dataclass
import math

from invrad_wb.core.output.metrics import grid_spacing  # noqa: F401 - the standard's grid

#: EN 12464-1:2021 4.4: the border zone of 0.5 m along the walls left out of a task area
#: (the default work plane's margin; surfaces are graded as seen from outside it)
BORDER_M = 0.5


@dataclass(frozen=True)
class RoomTypeRequirement:
    name: str
    task: str
    em_lux: float
    u0: float
    ugr_limit: float
    ra: int
    reference: str
    walls_lux: float = 50.0       # EN 12464-1:2021 5.2.3: every enclosed space
    ceiling_lux: float = 30.0
    cylindrical_lux: float = None  # Ez where people meet and talk (cylindrical.py)


#: EN 12464-1:2021 clause 5.2.3: the least maintained mean illuminance (lx) and U0 on the
#: walls and on the ceiling of every enclosed space
WALLS_MIN = (50.0, 0.10)
CEILING_MIN = (30.0, 0.10)
#: ... and in offices, education and health care premises
WALLS_MIN_OFFICE = (75.0, 0.10)
CEILING_MIN_OFFICE = (50.0, 0.10)
_OFFICE = dict(walls_lux=WALLS_MIN_OFFICE[0], ceiling_lux=CEILING_MIN_OFFICE[0],
               cylindrical_lux=150.0)
from invrad_wb.constants import SURFACE_REFERENCE  # noqa: E402,F401 - said in the report


_TABLE = (
    RoomTypeRequirement("office", "writing, typing, reading, data processing", 500, 0.60,
                        19, 80, "table 5.26",
                        **_OFFICE),
    RoomTypeRequirement("open_plan_office", "writing, typing, reading, data processing",
                        500, 0.60, 19, 80, "table 5.26",
                        **_OFFICE),
    RoomTypeRequirement("technical_drawing", "technical drawing", 750, 0.70, 16, 80,
                        "table 5.26",
                        **_OFFICE),
    RoomTypeRequirement("meeting_room", "conference and meeting rooms", 500, 0.60, 19, 80,
                        "table 5.26",
                        **_OFFICE),
    RoomTypeRequirement("reception", "reception desk", 300, 0.60, 22, 80, "table 5.26",
                        **_OFFICE),
    RoomTypeRequirement("archive", "archives", 200, 0.40, 25, 80, "table 5.26",
                        **_OFFICE),
    RoomTypeRequirement("corridor", "circulation areas and corridors", 100, 0.40, 28, 40,
                        "table 5.1"),
    RoomTypeRequirement("stairs", "stairs, escalators, travolators", 100, 0.40, 25, 40,
                        "table 5.1"),
    RoomTypeRequirement("rest_room", "rest rooms", 100, 0.40, 22, 80, "table 5.2"),
    RoomTypeRequirement("toilet", "cloakrooms, washrooms, bathrooms, toilets", 200, 0.40,
                        25, 80, "table 5.2"),
    RoomTypeRequirement("canteen", "canteens, pantries", 200, 0.40, 22, 80, "table 5.2"),
    RoomTypeRequirement("storeroom", "store and stock rooms", 100, 0.40, 25, 60,
                        "table 5.3"),
    RoomTypeRequirement("classroom", "classrooms, tutorial rooms", 500, 0.60, 19, 80,
                        "table 5.36",
                        **_OFFICE),
    RoomTypeRequirement("classroom_adult", "classrooms for evening classes and adult"
                        " education", 750, 0.60, 19, 80, "table 5.36",
                        **_OFFICE),
    RoomTypeRequirement("lecture_hall", "lecture halls", 500, 0.60, 19, 80, "table 5.36",
                        **_OFFICE),
    RoomTypeRequirement("workshop", "workshops: general machining and assembly", 500,
                        0.60, 22, 80, "table 5.x (industrial activities)"),
)
_BY_NAME = {r.name: r for r in _TABLE}


def names():
    """Known room type names."""
    return [r.name for r in _TABLE]


def lookup(name):
    """The :class:`RoomTypeRequirement` of a room type name (case and spaces ignored)."""
    if not isinstance(name, str):
        return None
    key = name.strip().lower().replace(" ", "_").replace("-", "_")
    return _BY_NAME.get(key)


def surface_minimums(room_type=None):
    """EN 12464-1:2021 least (lux, u0) of the walls and of the ceiling of a room type
    (offices and education: 75 / 50 lx; every other enclosed space: 50 / 30 lx)."""
    req = lookup(room_type) if room_type else None
    if req is None:
        return {"walls": WALLS_MIN, "ceiling": CEILING_MIN}
    return {"walls": (req.walls_lux, WALLS_MIN[1]), "ceiling": (req.ceiling_lux,
                                                               CEILING_MIN[1])}


def grid_counts(length, width):
    """Number of grid points along the two sides of a ``length x width`` rectangle: the
    side divided by ``p`` rounded up, so the cells are at most ``p`` on a side (and at
    least one point per side)."""
    p = grid_spacing(max(length, width))
    return (max(1, math.ceil(length / p - 1e-9)), max(1, math.ceil(width / p - 1e-9)))


def uniformity_for(lux):
    """The uniformity U0 (Emin/Em) that EN 12464-1:2021 pairs with a maintained
    illuminance of ``lux`` in its schedule (clause 5) when no room type says otherwise:
    0.40 below 500 lx, 0.60 from 500 lx, 0.70 from 750 lx. Returns (u0, words), e.g.
    ``(0.6, "EN 12464-1 for 500 lx")``."""
    lux = float(lux)
    u0 = 0.70 if lux >= 750 else 0.60 if lux >= 500 else 0.40
    return u0, f"EN 12464-1 for {lux:g} lx"

"""EN 12464-1 requirements of common room types, and its calculation grid.

Source: EN 12464-1:2021 "Light and lighting - Lighting of work places - Part 1: Indoor work
places", clause 5 (schedule of lighting requirements: maintained illuminance Em, uniformity
U0 = Emin/Em, unified glare rating limit UGR_L, colour rendering Ra) and clause 4.4/Annex on
the calculation grid. The table below holds the values commonly quoted for the room types
architects ask for most; it is a convenience, not a substitute for the standard: a
requirement stated in the design spec always wins. Residential rooms are not covered by
EN 12464-1; give their requirement explicitly.
"""
from dataclasses import dataclass
import math

from invrad_wb.core.output.metrics import grid_spacing  # noqa: F401 - the standard's grid


@dataclass(frozen=True)
class RoomTypeRequirement:
    name: str
    task: str
    em_lux: float
    u0: float
    ugr_limit: float
    ra: int
    reference: str


_TABLE = (
    RoomTypeRequirement("office", "writing, typing, reading, data processing", 500, 0.60,
                        19, 80, "table 5.26"),
    RoomTypeRequirement("open_plan_office", "writing, typing, reading, data processing",
                        500, 0.60, 19, 80, "table 5.26"),
    RoomTypeRequirement("technical_drawing", "technical drawing", 750, 0.70, 16, 80,
                        "table 5.26"),
    RoomTypeRequirement("meeting_room", "conference and meeting rooms", 500, 0.60, 19, 80,
                        "table 5.26"),
    RoomTypeRequirement("reception", "reception desk", 300, 0.60, 22, 80, "table 5.26"),
    RoomTypeRequirement("archive", "archives", 200, 0.40, 25, 80, "table 5.26"),
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
                        "table 5.36"),
    RoomTypeRequirement("classroom_adult", "classrooms for evening classes and adult"
                        " education", 750, 0.60, 19, 80, "table 5.36"),
    RoomTypeRequirement("lecture_hall", "lecture halls", 500, 0.60, 19, 80, "table 5.36"),
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


def grid_counts(length, width):
    """Number of grid points along the two sides of a ``length x width`` rectangle: the
    side divided by ``p`` rounded up, so the cells are at most ``p`` on a side (and at
    least one point per side)."""
    p = grid_spacing(max(length, width))
    return (max(1, math.ceil(length / p - 1e-9)), max(1, math.ceil(width / p - 1e-9)))

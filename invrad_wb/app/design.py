"""Design from requirements over a FreeCAD building (the document side of
:mod:`invrad_wb.core.design`).

A targets file (``--targets T.json``) with a ``catalogue`` is a design spec: its rooms are
keyed by room label/name (``"*"`` for every other room), a ``work_plane`` may be a number
(lux) or ``{"lux", "u0", "height_m", "margin_m"}``, and a ``room_type`` without a work
plane takes its EN 12464-1 values. The work-plane requirements also become the rooms'
work-plane targets in the document (so the report and the GUI show them); the pipeline then
designs instead of locating (:func:`invrad_wb.app.pipeline.run` with
``PipelineSettings.design``).
"""
import json
import os

from invrad_wb.errors import SceneError, SettingsError

_SPEC_ROOM_KEYS = ("work_plane", "room_type", "mounting", "catalogue", "shade_limit_lux",
                   "ugr_max", "walls", "ceiling", "cylindrical", "operating_hours",
                   "background")


def is_design_file(path):
    """True when a targets file is a design spec (it has a ``catalogue``)."""
    try:
        with open(path, "r", encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return False            # reported properly when the targets are applied
    return isinstance(data, dict) and "catalogue" in data


def spec_from_targets_file(path):
    """The :class:`~invrad_wb.core.design.spec.DesignSpec` of a design targets file."""
    from invrad_wb.core.design.spec import spec_from_dict
    try:
        with open(path, "r", encoding="utf-8") as fh:
            data = json.load(fh)
    except OSError as exc:
        raise SceneError(f"cannot read targets: {exc.strerror}", path)
    except ValueError as exc:
        raise SceneError(f"not valid JSON: {exc}", path)
    return spec_from_data(data, os.fspath(path), os.path.dirname(os.path.abspath(path)))


def spec_from_data(data, source, base_dir):
    """The :class:`~invrad_wb.core.design.spec.DesignSpec` of a design dict (a targets
    file's or the design panel's): room keys are labels/names, other target keys are left
    to the targets; raises SettingsError naming ``source`` and the key."""
    from invrad_wb.core.design.spec import spec_from_dict
    if not isinstance(data, dict):
        raise SettingsError(f"{source}: expected an object with catalogue and rooms")
    if not isinstance(data.get("rooms"), dict):
        raise SettingsError(f"{source}: rooms: expected an object of rooms")
    rooms = {}
    for key, room in data["rooms"].items():
        if not isinstance(room, dict):
            raise SettingsError(f"{source}: rooms: {key}: expected an object")
        r = {k: room[k] for k in _SPEC_ROOM_KEYS if k in room}
        if not isinstance(r.get("work_plane", {}), dict):
            r["work_plane"] = {"lux": r["work_plane"]}
        rooms[key] = r
    spec = {k: data[k] for k in ("maintenance_factor", "catalogue", "operating_hours")
            if k in data}
    spec["rooms"] = rooms
    return spec_from_dict(spec, source=source, base_dir=base_dir)


def work_planes_for(spaces, spec):
    """Give each of ``spaces`` that the spec has a work-plane requirement for, and that has
    no WorkPlane target, one at the required height and margin (the design's work plane
    is meshed from it). Document edit: call inside a transaction. Returns the Spaces
    changed."""
    from invrad_wb.app.rooms import room_name
    from invrad_wb.app.targets import set_work_plane, work_plane_target
    changed = []
    for sp in spaces:
        rs = spec.room_spec(sp.Name, room_name(sp))
        if rs is None or rs.work_plane is None or work_plane_target(sp) is not None:
            continue
        wp = rs.work_plane
        set_work_plane(sp, wp.lux, wp.height_m, wp.margin_m)
        changed.append(sp)
    return changed


def with_task_areas(room, space):
    """A design spec's room dict (``{"work_plane": {...}, ...}``) with the task areas of
    ``space``'s work-plane target (outlines drawn in the document, in metres) where the
    room gives none of its own: they replace the border zone (``margin_m``). The room
    dict unchanged where the document has none; raises SceneError naming the target and
    the outline at fault."""
    from invrad_wb.app.targets import task_areas_m, work_plane_target
    wp_obj = work_plane_target(space)
    if wp_obj is None or not isinstance(room, dict):
        return room
    wp = room.get("work_plane")
    wp = {} if wp is None else (dict(wp) if isinstance(wp, dict) else {"lux": wp})
    if wp.get("task_areas") is not None:
        return room
    areas = task_areas_m(wp_obj)
    if not areas:
        return room
    wp.pop("margin_m", None)
    wp["task_areas"] = areas
    return dict(room, work_plane=wp)


def design_summary(result):
    """Per-room design figures for the pipeline's summary (JSON-ready)."""
    return {"total_watts": round(result.watts, 2),
            "total_rated_watts": round(result.rated_watts, 2), "compliant": result.compliant,
            "maintenance_factor": result.spec.maintenance_factor,
            # each room with its dimming groups (members: indices into result.luminaires)
            "rooms": result.to_dict()["rooms"]}

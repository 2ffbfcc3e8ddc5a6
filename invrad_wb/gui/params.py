"""The workbench's settings, kept in FreeCAD's parameters between sessions.

Group ``User parameter:BaseApp/Preferences/Mod/InvRad`` (Tools > Edit parameters):

* ``Run``: the pipeline options of :class:`invrad_wb.app.pipeline.PipelineSettings` that a
  user chooses (flux, mesh resolution, interreflection, backend, replace, zones);
* ``Locate``: every field of :class:`invrad_wb.core.inverse.locate.LocateSettings`, under its own
  name; options whose default is "automatic" (``None`` in the core, e.g. ``votes_per_m2``)
  are stored as text, empty meaning automatic;
* ``Target``: the last values of the target task panel;
* ``Display``: the false-colour display (resolution, offset, work-plane transparency);
* ``Design``: the design panel's last spec (catalogue, requirements, maintenance factor) as
  DESIGN.json text under ``Spec`` (empty: :data:`DEFAULT_DESIGN`).

Headless-safe (only ``FreeCAD.ParamGet``), so the tests check it under freecadcmd. Values
are SI: lumens, metres, lux.
"""
import dataclasses
import math

from invrad_wb.app import settings as S

ROOT = "User parameter:BaseApp/Preferences/Mod/InvRad"

#: Options of a run that are not locate settings: name -> (kind, default).
RUN = {
    "flux_lm": ("float", 3000.0),
    "resolution_m": ("float", S.RESOLUTION_M),
    "interreflection": ("bool", True),
    "backend": ("str", "auto"),
    "replace": ("bool", True),
    # rooms open to each other (no wall between them) located as one lighting zone
    "zones": ("bool", True),
    "report_dir": ("str", ""),
    # rooms on worker processes (the Python FreeCAD embeds): 'auto' = one per core; '1' =
    # in FreeCAD's process. No widget: Tools > Edit parameters > Mod/InvRad > workers
    "workers": ("str", "auto"),
}

#: Locate settings whose core default is None ("automatic"): their value type.
OPTIONAL = {"votes_per_m2": "float", "dummy_count": "int", "dummy_lowest_m": "float",
            "shade_limit_lux": "float"}

#: Choices of the text-valued options (value, label), the task panel's combo boxes.
CHOICES = {
    "vote_model": [("exact", "Exact"), ("ellipse", "Ellipses")],
    "weighting": [("illumination", "By light"), ("distance", "By distance"),
                  ("both", "Both"), ("none", "None")],
    # short labels: the task panel is narrow (the tooltips say more)
    "occlusion": [("auto", "Auto"), (True, "On"), (False, "Off")],
    "optimiser": [("lm", "Least squares"), ("es", "(1+1)-ES")],
    "indirect": [("radiosity", "Radiosity"), ("ambient", "Ambient term"),
                 ("none", "None")],
    "backend": [("auto", "Auto"), ("opencl", "OpenCL"), ("numpy", "numpy")],
    "aim": [("fixed", "Fixed"), ("free", "Adjustable")],
}

TARGET = {
    "kind": ("str", "Uniform"),
    "lux": ("float", 300.0),
    "radius_m": ("float", 0.5),
    "falloff": ("str", "Cosine"),
    "lux_scale": ("float", 1.0),
    "image": ("str", ""),
    "height_m": ("float", S.WORK_PLANE_HEIGHT_M),
    "margin_m": ("float", S.WORK_PLANE_MARGIN_M),
}

DISPLAY = {
    "resolution_m": ("float", 0.1),
    "offset_m": ("float", 0.01),
    "work_plane_transparency": ("float", 0.25),
}


#: The design panel's first catalogue and requirement: generic round LED panels (a luminous
#: opening of 0.6 m across, so that UGR is computed from a real luminance: a point source
#: is rated as CIE 147's small source, which no office limit of 19 admits) and an
#: EN 12464-1 office; the architect replaces them with her own catalogue.
DEFAULT_DESIGN = {
    "maintenance_factor": 0.8,
    "catalogue": [
        {"name": "Panel 1000 lm", "flux_lm": 1000.0, "watts": 8.5, "radius_m": 0.3},
        {"name": "Panel 2000 lm", "flux_lm": 2000.0, "watts": 15.5, "radius_m": 0.3},
        {"name": "Panel 3500 lm", "flux_lm": 3500.0, "watts": 26.0, "radius_m": 0.3,
         "dimming": [0.1, 1.0]},
    ],
    "rooms": {"*": {"room_type": "office"}},
}


def load_design():
    """The stored design spec as a dict (a copy of :data:`DEFAULT_DESIGN` if none or
    unreadable)."""
    import copy
    import json
    text = group("Design").GetString("Spec", "")
    try:
        d = json.loads(text) if text else None
    except ValueError:
        d = None
    return d if isinstance(d, dict) else copy.deepcopy(DEFAULT_DESIGN)


def save_design(spec):
    import json
    group("Design").SetString("Spec", json.dumps(spec))


def group(name):
    import FreeCAD
    return FreeCAD.ParamGet(f"{ROOT}/{name}")


def locate_fields():
    """``{name: (kind, default)}`` for every LocateSettings field."""
    from invrad_wb.core.inverse.locate import LocateSettings
    out = {}
    for f in dataclasses.fields(LocateSettings):
        default = f.default
        if f.name == "occlusion":
            kind = "occlusion"
        elif f.name in OPTIONAL or default is None:
            kind = "opt" + OPTIONAL.get(f.name, "float")
        elif isinstance(default, bool):
            kind = "bool"
        elif isinstance(default, int):
            kind = "int"
        elif isinstance(default, float):
            kind = "float"
        else:
            kind = "str"
        out[f.name] = (kind, default)
    return out


def _get(grp, name, kind, default):
    if kind == "float":
        return float(grp.GetFloat(name, float(default)))
    if kind == "int":
        return int(grp.GetInt(name, int(default)))
    if kind == "bool":
        return bool(grp.GetBool(name, bool(default)))
    if kind == "str":
        return grp.GetString(name, str(default))
    if kind == "occlusion":
        text = grp.GetString(name, _occlusion_text(default)).strip().lower()
        return {"auto": "auto", "true": True, "on": True, "false": False,
                "off": False}.get(text, default)
    if kind.startswith("opt"):
        text = grp.GetString(name, "" if default is None else str(default)).strip()
        if text == "" or text.lower() == "auto":
            return None
        try:
            v = float(text)
        except ValueError:
            return default
        return int(v) if kind == "optint" else v
    raise ValueError(f"unknown parameter kind {kind!r}")


def _occlusion_text(value):
    return {True: "true", False: "false"}.get(value, "auto")


def _set(grp, name, kind, value):
    if kind == "float":
        grp.SetFloat(name, float(value))
    elif kind == "int":
        grp.SetInt(name, int(value))
    elif kind == "bool":
        grp.SetBool(name, bool(value))
    elif kind == "str":
        grp.SetString(name, str(value))
    elif kind == "occlusion":
        grp.SetString(name, _occlusion_text(value))
    elif kind.startswith("opt"):
        if value is None or (isinstance(value, float) and math.isnan(value)):
            grp.SetString(name, "")
        else:
            grp.SetString(name, repr(int(value) if kind == "optint" else float(value)))
    else:
        raise ValueError(f"unknown parameter kind {kind!r}")


def _load(name, schema):
    grp = group(name)
    return {k: _get(grp, k, kind, default) for k, (kind, default) in schema.items()}


def _save(name, schema, values):
    grp = group(name)
    for k, v in values.items():
        if k in schema:
            _set(grp, k, schema[k][0], v)


def load_locate():
    """The stored locate settings as a checked dict (bad stored values -> defaults)."""
    from invrad_wb.core.inverse.locate import LocateSettings
    from invrad_wb.errors import SettingsError
    fields = locate_fields()
    values = _load("Locate", fields)
    try:
        LocateSettings.from_dict(values)
        return values
    except (SettingsError, TypeError, ValueError):
        pass
    good = {}
    for k, v in values.items():                 # keep what is valid on its own
        try:
            LocateSettings.from_dict({k: v})
            good[k] = v
        except (SettingsError, TypeError, ValueError):
            good[k] = fields[k][1]
    try:
        LocateSettings.from_dict(good)
        return good
    except (SettingsError, TypeError, ValueError):
        return {k: d for k, (_, d) in fields.items()}


def save_locate(values):
    _save("Locate", locate_fields(), values)


def load_run():
    return _load("Run", RUN)


def save_run(values):
    _save("Run", RUN, values)


def load_target():
    return _load("Target", TARGET)


def save_target(values):
    _save("Target", TARGET, values)


def load_display():
    return _load("Display", DISPLAY)


def reset():
    """Forget every stored value (back to the defaults)."""
    for name in ("Run", "Locate", "Target", "Display", "Design"):
        group(name).Clear()


def pipeline_settings(rooms=None, report_dir=None, insert=True, run=None, locate=None):
    """A PipelineSettings from the stored values (``run``/``locate`` dicts override)."""
    from invrad_wb.app.pipeline import PipelineSettings
    r = load_run()
    r.update(run or {})
    loc = load_locate()
    loc.update(locate or {})
    from invrad_wb.core.accel.workers import check_workers
    from invrad_wb.errors import SettingsError
    try:
        workers = check_workers(r["workers"])
    except SettingsError as exc:
        raise SettingsError(f"preference {ROOT.split(':', 1)[1]}/workers: {exc}") from None
    return PipelineSettings(flux_lm=r["flux_lm"], resolution_m=r["resolution_m"],
                            interreflection=r["interreflection"], locate=loc,
                            backend=r["backend"], replace=r["replace"], rooms=rooms,
                            report_dir=report_dir, insert=insert, workers=workers,
                            zones=r["zones"])

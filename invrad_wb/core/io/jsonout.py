"""JSON output that any strict reader accepts (numpy values, no NaN)."""
import json

import numpy as np

from invrad_wb.core.io.atomic import atomic_write_text


def jsonable(o):
    """``json.dumps`` default: numpy arrays and scalars as plain values, else ``str(o)``."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    return str(o)


def _clean(o):
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    if isinstance(o, np.ndarray):
        return _clean(o.tolist())
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        o = o.item()
    if isinstance(o, float) and not np.isfinite(o):
        return None
    return o


def dumps(data, indent=2):
    """Strict JSON text (NaN and infinities become null), newline-terminated."""
    return json.dumps(_clean(data), indent=indent, allow_nan=False, default=jsonable) + "\n"


def write_luminaires_json(path, luminaires, **extra):
    """Write ``{"luminaires": [...], **extra}`` atomically (luminaires: anything with
    ``to_dict()``, e.g. :class:`invrad_wb.core.model.luminaires.Luminaire`)."""
    data = {"luminaires": [l.to_dict() for l in luminaires]}
    data.update(extra)
    atomic_write_text(path, json.dumps(data, indent=2, default=_json_default) + "\n")


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(f"cannot serialise {type(o).__name__}")

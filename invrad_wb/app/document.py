"""Document-level helpers: undoable transactions, the active document, object lookup.

Every change invrad makes to a document goes through :func:`transaction`, so that it is
one undo step, and so that a failure (an exception, a cancel) leaves the document exactly
as it was (``abortTransaction``).

FreeCAD 0.20 quirk: documents made or opened by ``freecadcmd`` have ``UndoMode == 0``, in
which ``openTransaction``/``abortTransaction`` silently do nothing. :func:`transaction`
switches undo on for the document first.
"""
import contextlib
import threading

_state = threading.local()


def _depth():
    if not hasattr(_state, "depth"):
        _state.depth = {}
    return _state.depth


@contextlib.contextmanager
def transaction(doc, name):
    """One undoable change of ``doc``; aborted (the document unchanged) on any exception.

    Nested uses for the same document join the outermost transaction, so that helper
    functions can be transactional on their own and still compose into one undo step.
    The document is recomputed before the transaction is committed.
    """
    depth = _depth()
    key = doc.Name
    if depth.get(key):
        depth[key] += 1
        try:
            yield doc
        finally:
            depth[key] -= 1
        return
    if not doc.UndoMode:
        doc.UndoMode = 1
    active = activate(doc)
    doc.openTransaction(name)
    depth[key] = 1
    try:
        yield doc
        doc.recompute()
    except BaseException:
        depth[key] = 0
        doc.abortTransaction()
        doc.recompute()
        _restore_active(active)
        raise
    depth[key] = 0
    doc.commitTransaction()
    _restore_active(active)


def activate(doc):
    """Make ``doc`` the active document (Arch's make* functions use the active one).

    Returns the previously active document's name (or None).
    """
    import FreeCAD
    prev = FreeCAD.ActiveDocument.Name if FreeCAD.ActiveDocument else None
    if prev != doc.Name:
        FreeCAD.setActiveDocument(doc.Name)
    return prev


def _restore_active(name):
    import FreeCAD
    if name and name in FreeCAD.listDocuments():
        FreeCAD.setActiveDocument(name)


def object_type(obj):
    """The Draft/Arch type of an object ('Space', 'Equipment', 'InvRadTarget', ...)."""
    proxy = getattr(obj, "Proxy", None)
    t = getattr(proxy, "Type", None)
    if isinstance(t, str):
        return t
    return obj.TypeId


def describe(obj):
    """``'Label' (Name)`` for messages; just ``'Label'`` when both are the same."""
    if obj is None:
        return "(none)"
    try:
        label, name = obj.Label, obj.Name
        # a NativeIFC IfcSpace is labelled with its IFC Name ("5"); its room name is the
        # LongName ("Wohnen")
        long_name = (getattr(obj, "LongName", "") if "IfcClass" in obj.PropertiesList
                     else "")
    except Exception:          # deleted object
        return "(deleted object)"
    if long_name and long_name not in (label, "None"):
        return f"'{long_name}' ({label}, {name})"
    return f"'{label}'" if label == name else f"'{label}' ({name})"


def snapshot(doc):
    """A comparable summary of a document: objects and their main property values.

    Used by tests to check that a failed or cancelled run left the document unchanged.
    """
    out = {}
    for o in doc.Objects:
        props = {}
        for p in o.PropertiesList:
            if p in ("Shape", "Proxy", "ExpressionEngine", "Visibility", "Label2",
                     "AttacherType", "Support", "MapMode"):
                continue
            try:
                val = getattr(o, p)
            except Exception:
                continue
            props[p] = _comparable(val)
        shape = getattr(o, "Shape", None)
        if shape is not None and hasattr(shape, "isNull") and not shape.isNull():
            bb = shape.BoundBox
            props["_shape"] = (len(shape.Faces), round(bb.XMin, 3), round(bb.YMin, 3),
                               round(bb.ZMin, 3), round(bb.XMax, 3), round(bb.YMax, 3),
                               round(bb.ZMax, 3))
        out[o.Name] = props
    return out


def _comparable(val):
    if hasattr(val, "Name") and hasattr(val, "TypeId"):
        return ("obj", val.Name)
    if isinstance(val, (list, tuple)):
        return tuple(_comparable(v) for v in val)
    if isinstance(val, dict):
        return tuple(sorted((k, _comparable(v)) for k, v in val.items()))
    if hasattr(val, "Base") and hasattr(val, "Rotation"):           # Placement
        return ("placement", _comparable(val.Base), tuple(round(q, 9) for q in val.Rotation.Q))
    if hasattr(val, "x") and hasattr(val, "z"):                      # Vector
        return (round(val.x, 6), round(val.y, 6), round(val.z, 6))
    if hasattr(val, "Value") and hasattr(val, "Unit"):               # Quantity
        return _comparable(float(val.Value))
    if isinstance(val, float):
        return "nan" if val != val else round(val, 9)
    if isinstance(val, (str, int, bool)) or val is None:
        return val
    return repr(val)


def global_shape(obj, shape=None):
    """A copy of ``obj.Shape`` (or ``shape``) in global coordinates (mm): FreeCAD keeps an
    object's shape in the frame of the BuildingPart/storey it is in."""
    shape = (obj.Shape if shape is None else shape).copy()
    gp = obj.getGlobalPlacement()
    own = obj.Placement
    if not gp.toMatrix() == own.toMatrix():
        shape.Placement = gp.multiply(own.inverse()).multiply(shape.Placement)
    return shape

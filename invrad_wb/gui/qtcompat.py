"""What differs between the PySide2 (Qt 5) and PySide6 (Qt 6) that FreeCAD may be built
with, behind FreeCAD's own ``PySide`` shim (which maps QtGui/QtWidgets names on both).

* ``exec_()`` is PySide2's name; PySide6 has ``exec()`` (``exec_`` only as a deprecated
  alias): :func:`run_exec` calls whichever the object has.
* Qt 6 enums are Python ``enum`` flags: ``int(Ok | Cancel)`` fails on a plain
  ``enum.Flag``; :func:`flag_int` takes ``.value`` where there is one.
"""


def run_exec(obj):
    """``obj.exec()`` (Qt 6) or ``obj.exec_()`` (Qt 5): run a dialog or event loop."""
    fn = getattr(obj, "exec", None)
    if fn is None:
        fn = obj.exec_
    return fn()


def flag_int(flags):
    """An enum flag combination as an int on PySide2 and PySide6."""
    return int(getattr(flags, "value", flags))

"""The FreeCAD GUI of invrad: commands, task panels, false-colour display, progress.

Loaded by ``InitGui.py`` when the workbench is first activated, and only with FreeCAD's
GUI: the modules import ``FreeCADGui``, PySide and pivy inside their functions, so that
they can be imported (and their numpy parts tested) under freecadcmd as well.

* :mod:`.commands`   the ``InvRad_*`` commands, toolbar/menu layout, :func:`register`
* :mod:`.taskpanel`  task panels on ``resources/ui/*.ui`` (locate settings, target, peaks)
* :mod:`.runner`     locate / recalculate peaks / verify with progress, stored results
* :mod:`.progress`   worker thread + progress dialog with Cancel
* :mod:`.display`    false-colour overlay of targets or achieved illuminance + legend
* :mod:`.selection`  selected faces -> faces of rooms (Space faces or wall faces on them)
* :mod:`.params`     settings kept in FreeCAD's parameters
* :mod:`.messages`   errors and results to the report view and dialog boxes
* :mod:`.qtcompat`   PySide2 / PySide6 differences (exec, enum flags)
* :mod:`.bim`        the InvRad toolbar in the BIM workbench (a custom toolbar)
"""

"""InvRad's toolbar in FreeCAD's BIM workbench (FreeCAD 1.x), where architects work.

FreeCAD builds a workbench's toolbars from its own list plus the user's custom toolbars
(*Tools > Customize > Toolbars*), kept in the parameters
``BaseApp/Workbench/<workbench>/Toolbar/<group>``: ``Name`` is the toolbar's title, every
other string is a command name whose value is the Python module FreeCAD imports when the
command is not registered yet (Gui::Workbench::setupCustomToolbars). :func:`offer_toolbar`
adds such a toolbar "InvRad" to the BIM workbench once, the first time the InvRad
workbench is activated; importing this module registers the commands, so the toolbar
works in a session where the InvRad workbench was never opened. A user who removes or
deactivates it in *Customize* keeps it that way (the group is only written when absent).
"""
from invrad_wb.app import dependencies

BIM_WORKBENCH = "BIMWorkbench"
GROUP = "InvRad"
PARAM = f"User parameter:BaseApp/Workbench/{BIM_WORKBENCH}/Toolbar"


def offer_toolbar():
    """Add the InvRad toolbar to the BIM workbench's custom toolbars if it is not there.

    Returns True when it was added now (False: no BIM workbench, or already there).
    """
    import FreeCAD
    if not FreeCAD.GuiUp:
        return False
    import FreeCADGui
    from invrad_wb.gui import commands
    listing = getattr(FreeCADGui, "listWorkbenches", None)
    if listing is None or BIM_WORKBENCH not in listing():
        return False
    bars = FreeCAD.ParamGet(PARAM)
    if bars.HasGroup(GROUP):
        return False
    grp = bars.GetGroup(GROUP)
    grp.SetString("Name", "InvRad")
    grp.SetBool("Active", True)
    n = 0
    for cmd in commands.TOOLBAR:
        if cmd == "Separator":
            n += 1
            grp.SetString(f"Separator{n}", "Separator")
        else:
            grp.SetString(cmd, __name__)
    return True


def _register():
    import FreeCAD
    if FreeCAD.GuiUp:
        dependencies.add_site_packages()
        from invrad_wb.gui import commands
        commands.register()


_register()

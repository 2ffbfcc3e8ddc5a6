# The tests in this folder need FreeCAD: they run under freecadcmd (tests/freecad/run.py),
# not under pytest.
collect_ignore_glob = ["*.py"]

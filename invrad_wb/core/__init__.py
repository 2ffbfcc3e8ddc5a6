"""The FreeCAD-free core of invrad: scenes, forward solver, votes, peaks, reports."""

"""Lighting design from requirements: spec (requirements + catalogue), EN 12464-1 values and
grid, room geometry, candidate layouts, the fast and exact light models, the search, and
the whole-scene :func:`~invrad_wb.core.design.design.design`."""

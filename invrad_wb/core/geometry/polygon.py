"""Plan polygons: signed area and simplicity (a task area's outline, :mod:`invrad_wb.core.design.spec`)."""
import numpy as np


def polygon_area(poly):
    """Signed area (m^2, positive counter-clockwise) of a plan polygon."""
    p = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def self_intersection(poly):
    """The first pair of edges (i, j) of a polygon that cross or touch (not neighbours),
    or None: a simple polygon."""
    p = [tuple(map(float, x)) for x in poly]
    n = len(p)

    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return 0 if abs(v) < 1e-12 else (1 if v > 0 else -1)

    def on_seg(a, b, c):
        return (min(a[0], b[0]) - 1e-12 <= c[0] <= max(a[0], b[0]) + 1e-12
                and min(a[1], b[1]) - 1e-12 <= c[1] <= max(a[1], b[1]) + 1e-12)

    def cross(a, b, c, d):
        o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
        if o1 != o2 and o3 != o4:
            return True
        return ((o1 == 0 and on_seg(a, b, c)) or (o2 == 0 and on_seg(a, b, d))
                or (o3 == 0 and on_seg(c, d, a)) or (o4 == 0 and on_seg(c, d, b)))

    for i in range(n):
        a, b = p[i], p[(i + 1) % n]
        for j in range(i + 1, n):
            if j == i or (j + 1) % n == i or j == (i + 1) % n:
                continue         # neighbours share a corner
            if cross(a, b, p[j], p[(j + 1) % n]):
                return i, j
    return None

"""Plan polygons: signed area, edges, simplicity and segment crossings (a task area's
outline, :mod:`invrad_wb.core.design.spec`; the room's outline,
:mod:`invrad_wb.core.design.room`)."""
import numpy as np

from invrad_wb.core.geometry.components import component_labels


def polygon_area(poly):
    """Signed area (m^2, positive counter-clockwise) of a plan polygon."""
    p = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]))


def polygon_edges(poly):
    """(k, 2, 2) edges of a closed plan polygon (k, 2): corner i to corner i + 1, the last
    back to the first."""
    p = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
    return np.stack([p, np.roll(p, -1, axis=0)], axis=1)


def edges_3d(edges):
    """Plan segments (k, 2, 2) lifted to z = 0, (k, 2, 3) (for
    :func:`~invrad_wb.core.model.targets.distance_to_segments`)."""
    e = np.asarray(edges, dtype=np.float64).reshape(-1, 2, 2)
    return np.concatenate([e, np.zeros(e.shape[:2] + (1,))], axis=2)


def drop_repeats(poly):
    """A polygon's corners less consecutive repeats (a corner given twice, the first point
    repeated at the end to close it)."""
    out = []
    for p in poly:
        if not out or tuple(p) != tuple(out[-1]):
            out.append(p)
    while len(out) > 1 and tuple(out[0]) == tuple(out[-1]):
        out.pop()
    return tuple(out)


def _orient(a, b, c, tol):
    """-1, 0, 1: the side of ``c`` from the line ``a`` -> ``b`` (0 within ``tol`` m of it)."""
    v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    return 0 if abs(v) <= tol * max(np.hypot(b[0] - a[0], b[1] - a[1]), 1e-300) else (
        1 if v > 0 else -1)


def _on_seg(a, b, c, tol):
    return (min(a[0], b[0]) - tol <= c[0] <= max(a[0], b[0]) + tol
            and min(a[1], b[1]) - tol <= c[1] <= max(a[1], b[1]) + tol)


def segments_cross(a, b, c, d, touch=True, tol=1e-12):
    """Whether plan segments ``a``-``b`` and ``c``-``d`` cross: properly (each one's ends
    strictly on both sides of the other's line, ``tol`` m counted as on it) or, with
    ``touch``, also where one's end lies on the other (within ``tol``)."""
    o1, o2, o3, o4 = (_orient(a, b, c, tol), _orient(a, b, d, tol), _orient(c, d, a, tol),
                      _orient(c, d, b, tol))
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    if not touch:
        return False
    return ((o1 == 0 and _on_seg(a, b, c, tol)) or (o2 == 0 and _on_seg(a, b, d, tol))
            or (o3 == 0 and _on_seg(c, d, a, tol)) or (o4 == 0 and _on_seg(c, d, b, tol)))


def crossing_t(a, b, c, d):
    """The parameter along ``a``-``b`` where its line meets the line of ``c``-``d``."""
    r, s = np.subtract(b, a), np.subtract(d, c)
    den = r[0] * s[1] - r[1] * s[0]
    q = np.subtract(c, a)
    return float((q[0] * s[1] - q[1] * s[0]) / den)


def self_intersection(poly):
    """The first pair of edges (i, j) of a polygon that cross or touch (not neighbours),
    or None: a simple polygon."""
    p = [tuple(map(float, x)) for x in poly]
    n = len(p)
    for i in range(n):
        a, b = p[i], p[(i + 1) % n]
        for j in range(i + 1, n):
            if j == i or (j + 1) % n == i or j == (i + 1) % n:
                continue         # neighbours share a corner
            if segments_cross(a, b, p[j], p[(j + 1) % n]):
                return i, j
    return None


def edge_loops(segments, tol=1e-6):
    """The closed loops of an outline given as unordered segments (k, 2, 2): a list of
    index arrays, the segments of each connected run (ends welded within ``tol``)."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    k = len(seg)
    if not k:
        return []
    key = np.round(seg.reshape(-1, 2) / tol).astype(np.int64)
    _, node = np.unique(key, axis=0, return_inverse=True)
    node = node.reshape(k, 2)
    first = {}
    roots = component_labels(k, ((i, first.setdefault(int(v), i))
                                 for i in range(k) for v in node[i]))
    return [np.flatnonzero(roots == r) for r in np.unique(roots)]

"""Points inside a room's plan outline: the outline as edges (e, 2, 2), metres."""
import numpy as np


def inside_outline(edges, p):
    """Which plan points ``p`` (k, 2) lie inside the outline ``edges`` (e, 2, 2): even-odd
    rule, a ray along +x."""
    a, b = edges[:, 0], edges[:, 1]
    y = p[:, 1:2]
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (np.count_nonzero(crosses & (p[:, :1] < x_at), axis=1) % 2) == 1


def outline_raster(edges, n):
    """The points of an n x n raster over the outline's bounding box that lie inside it
    (m, 2), with the box's corners ``lo`` and ``hi`` (2,)."""
    lo, hi = edges.reshape(-1, 2).min(axis=0), edges.reshape(-1, 2).max(axis=0)
    g = np.stack(np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n)),
                 -1).reshape(-1, 2)
    return g[inside_outline(edges, g)], lo, hi

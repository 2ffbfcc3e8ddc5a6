"""component_labels: connected components of pairs, against a breadth-first search."""
import numpy as np

from invrad_wb.core.geometry.components import component_labels


def _bfs_labels(n, pairs):
    nb = [[] for _ in range(n)]
    for a, b in pairs:
        nb[a].append(b)
        nb[b].append(a)
    out = np.full(n, -1)
    for s in range(n):
        if out[s] >= 0:
            continue
        todo, seen = [s], {s}
        while todo:
            i = todo.pop()
            for j in nb[i]:
                if j not in seen:
                    seen.add(j)
                    todo.append(j)
        out[sorted(seen)] = min(seen)
    return out


def test_labels_are_each_components_smallest_index():
    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 40):
        for m in (0, n // 2, 2 * n):
            pairs = [tuple(rng.integers(0, n, 2)) for _ in range(m)]
            np.testing.assert_array_equal(component_labels(n, pairs), _bfs_labels(n, pairs))
    assert component_labels(0, []).shape == (0,)
    # a chain joined from its far end: one component labelled 0
    np.testing.assert_array_equal(component_labels(4, [(3, 2), (2, 1), (1, 0)]), [0] * 4)

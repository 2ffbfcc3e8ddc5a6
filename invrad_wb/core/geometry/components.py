"""Connected components of elements joined in pairs (union-find)."""
import numpy as np


def component_labels(n, pairs):
    """(n,) int64: for each of ``n`` elements the smallest index of its connected
    component, the components being those of the joined ``pairs`` ((a, b) indices;
    union-find with path halving, the larger root attached to the smaller)."""
    parent = list(range(n))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for a, b in pairs:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(n)], dtype=np.int64)

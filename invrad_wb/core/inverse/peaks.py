"""Post-processing of vote maps into candidate luminaire positions (thesis 4.2.4).

1. Laplace filter to enhance local maxima: the maps are lightly smoothed (Gaussian, sigma
   ``smooth_px`` pixels) and the negative Laplacian (3x3 kernel) is taken, computed only from
   neighbours on the map's mask so that face borders make no false edges.
2. Non-maxima suppression: a pixel survives if no pixel within ``neighbourhood`` metres is
   higher (and, on dummy layers, if it is at least ``DUMMY_WALL_GAP_M`` from the room's
   outline: pendants do not hang against walls) (dummy layers of one side are treated as a 3-D stack: the layer above and below
   count as neighbours, so a pendant's accumulation point is kept at its sharpest height).
3. Joint scaling of all maps (planes and dummy planes together) to 0-255.
4. Threshold (0-254): every surviving pixel above it is a candidate; candidates get a
   sub-pixel position (parabola through the smoothed map), a 3-D position and the facing
   normal of their map.

Running this again with a new threshold or neighbourhood needs only the stored vote buffer
(no new votes).

The three image filters (Gaussian blur, maximum over a disk, erosion by a square) are
written here in numpy, the same numbers as ``scipy.ndimage``'s (``tests/core/inverse/
test_peaks_filters.py`` compares them bit for bit): importing ``scipy.ndimage`` (it brings
``scipy.special``) was 0.05-0.1 CPU s of every command-line run, a third of that in a
room without interreflection, where nothing else of scipy is imported.
"""
from dataclasses import dataclass

import numpy as np

from invrad_wb.errors import SettingsError


@dataclass
class Peak:
    """A candidate luminaire position from the vote maps.

    Attributes
    ----------
    map_index : int
    ij : (2,) float64 continuous pixel coordinates (pixel centres at +0.5)
    position : (3,) float64, metres
    normal : (3,) float64, facing direction
    score : float, 0-255 after joint scaling
    votes : float, raw (smoothed) votes at the peak
    kind : 'surface' or 'dummy'
    plane : int (surface maps) or -1
    room : int
    """

    map_index: int
    ij: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    score: float
    votes: float
    kind: str
    plane: int
    room: int


def _masked_blur(a, mask, sigma):
    """Normalised convolution: Gaussian blur using only masked pixels (kernel radius
    ``ceil(3 sigma)``, at least 1 pixel; outside the map counts as unmasked)."""
    if sigma <= 0:
        return np.where(mask, a, 0.0)
    r = max(1, int(np.ceil(3 * sigma)))

    def blur(img):
        return gaussian_blur(img, sigma, r)

    w = blur(mask.astype(np.float64))
    num = blur(np.where(mask, a, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(w > 1e-6, num / w, 0.0)
    return np.where(mask, out, 0.0)


def _gaussian_weights(sigma, radius):
    """The normalised Gaussian of ``scipy.ndimage``'s ``_gaussian_kernel1d`` (order 0):
    weights at offsets -radius..radius, computed as there."""
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (sigma * sigma) * x ** 2)
    return phi / phi.sum()


def _correlate_symmetric(a, w, axis):
    """``a`` correlated along ``axis`` with the symmetric odd kernel ``w``, zeros beyond the
    ends: ``scipy.ndimage.correlate1d(a, w, axis, mode='constant', cval=0)`` for float64,
    with its arithmetic in its order (``ni_filters.c``: the centre term, then the outer
    pairs first, each pair summed before its weight multiplies it)."""
    r = len(w) // 2
    a = np.moveaxis(a, axis, 0)
    n = a.shape[0]
    pad = np.zeros((n + 2 * r,) + a.shape[1:])
    pad[r:r + n] = a
    out = pad[r:r + n] * w[r]
    t = np.empty_like(out)
    for j in range(r, 0, -1):
        np.add(pad[r - j:r - j + n], pad[r + j:r + j + n], out=t)
        t *= w[r - j]
        out += t
    return np.moveaxis(out, 0, axis)


def gaussian_blur(img, sigma, radius):
    """``scipy.ndimage.gaussian_filter(img, sigma, mode='constant', cval=0.0,
    radius=radius)`` of a 2-D float64 image (rows, then columns), in numpy."""
    img = np.asarray(img, dtype=np.float64)
    if not sigma > 1e-15:
        return img.copy()
    w = _gaussian_weights(sigma, int(radius))
    out = img
    for axis in range(img.ndim):
        out = _correlate_symmetric(out, w, axis)
    return np.ascontiguousarray(out)


def laplace_response(a, mask):
    """Negative 3x3 Laplacian from masked neighbours only, clipped at 0 (peaks > 0)."""
    p = np.pad(a, 1)
    pm = np.pad(mask, 1)
    acc = np.zeros_like(a)
    cnt = np.zeros_like(a)
    c = p[1:-1, 1:-1]
    for di, dj in ((0, 1), (2, 1), (1, 0), (1, 2)):
        nb = p[di:di + a.shape[0], dj:dj + a.shape[1]]
        nm = pm[di:di + a.shape[0], dj:dj + a.shape[1]]
        acc += np.where(nm, c - nb, 0.0)
        cnt += nm
    # a missing neighbour counts as equal to the centre (no rescaling: scaling the sum up by
    # 4 / count made corner pixels, with two neighbours, look twice as peaked)
    return np.where(mask & (cnt > 0), np.maximum(acc, 0.0), 0.0)


def _disk(r):
    """Footprint of a disk of radius r pixels: (2r+1, 2r+1) bool."""
    d = np.arange(-r, r + 1)
    return d[:, None] ** 2 + d[None, :] ** 2 <= r * r + 1e-9


def _max_filter(a, r):
    """Maximum over a disk of radius r pixels (r >= 1); outside the map counts as -inf
    (``scipy.ndimage.maximum_filter(a, footprint=_disk(r), mode='constant',
    cval=-inf)``; a maximum is exact in any order)."""
    r = int(r)
    a = np.asarray(a)
    if np.isnan(a).any():
        # NaN is not ordered: leave its (order-dependent) answer to scipy
        from scipy import ndimage
        return ndimage.maximum_filter(a, footprint=_disk(r), mode="constant",
                                      cval=-np.inf)
    nu, nv = a.shape
    pad = np.full((nu + 2 * r, nv + 2 * r), -np.inf, dtype=a.dtype)
    pad[r:r + nu, r:r + nv] = a
    out = a.copy()
    for di, dj in zip(*np.nonzero(_disk(r))):
        if di != r or dj != r:
            np.maximum(out, pad[di:di + nu, dj:dj + nv], out=out)
    return out


#: no mid-air candidate closer than this to the room's outline (metres)
DUMMY_WALL_GAP_M = 0.2


def _erode(mask, r):
    """Pixels of ``mask`` whose (2r+1)^2 square lies wholly in it (outside counts as off)."""
    # (scipy.ndimage.binary_erosion with that square and border_value 0: the rows' run,
    # then the columns')
    m = np.asarray(mask, dtype=bool)
    for axis in (0, 1):
        m = np.moveaxis(m, axis, 0)
        n = m.shape[0]
        pad = np.zeros((n + 2 * r,) + m.shape[1:], bool)
        pad[r:r + n] = m
        out = m.copy()
        for k in range(2 * r + 1):
            out &= pad[k:k + n]
        m = np.moveaxis(out, 0, axis)
    return np.ascontiguousarray(m)


def _subpixel(s, i, j):
    def par(m1, c0, p1):
        den = m1 - 2 * c0 + p1
        return 0.0 if den >= 0 else float(np.clip(0.5 * (m1 - p1) / den, -0.5, 0.5))
    di = par(s[i - 1, j], s[i, j], s[i + 1, j]) if 0 < i < s.shape[0] - 1 else 0.0
    dj = par(s[i, j - 1], s[i, j], s[i, j + 1]) if 0 < j < s.shape[1] - 1 else 0.0
    return np.array([i + 0.5 + di, j + 0.5 + dj])


def find_peaks(canvas, flat_votes, threshold=32.0, neighbourhood=0.3, smooth_px=1.0,
               max_peaks=None):
    """Candidate luminaire positions from a vote buffer.

    Parameters
    ----------
    canvas : VoteCanvas
    flat_votes : (canvas.size,) float32
    threshold : float in [0, 254]
        Keep peaks whose jointly scaled response exceeds this (254: only the best).
    neighbourhood : float, metres
        Non-maxima suppression radius.
    smooth_px : float
        Gaussian sigma (pixels) applied before the Laplace filter.

    Returns
    -------
    peaks : list of Peak, best first
    responses : list of (nu, nv) float64 scaled 0-255 responses (after NMS), per map
    """
    if not (0 <= threshold <= 254):
        raise SettingsError(f"threshold must be in [0, 254], got {threshold!r}")
    if not np.isfinite(neighbourhood) or neighbourhood < 0:
        raise SettingsError(f"neighbourhood must be >= 0 metres, got {neighbourhood!r}")
    maps = canvas.split(np.asarray(flat_votes, dtype=np.float64))
    smooth, resp = [], []
    for m, a in zip(canvas.maps, maps):
        s = _masked_blur(a, m.mask, smooth_px)
        smooth.append(s)
        resp.append(laplace_response(s, m.mask))
    r_px = max(1, int(round(neighbourhood / canvas.pixel)))
    keep = []
    for k, (m, r) in enumerate(zip(canvas.maps, resp)):
        local = _max_filter(r, r_px)
        if m.kind == "dummy":
            # 3-D suppression across neighbouring layers of the same side
            for k2, m2 in enumerate(canvas.maps):
                if (k2 != k and m2.kind == "dummy" and abs(m2.layer - m.layer) == 1
                        and np.allclose(m2.normal, m.normal) and m2.shape == m.shape):
                    local = np.maximum(local, _max_filter(resp[k2], r_px))
                    local = np.maximum(local, resp[k2])
        # no candidates on the outermost pixel ring of a map: half of such a pixel is off the
        # faces, and votes of points right next to the border pile up there
        allowed = _erode(m.mask, 1)
        if m.kind == "dummy":
            # pendants hang away from walls: no candidates in the border band of a dummy
            # layer, where votes from the walls pile up against the room's outline
            allowed = _erode(m.mask, max(1, int(round(DUMMY_WALL_GAP_M / canvas.pixel))))
        keep.append((r >= local) & (r > 0) & allowed)
    top = max([float(r[kp].max()) for r, kp in zip(resp, keep) if kp.any()], default=0.0)
    scaled = [np.where(kp, r * (255.0 / top), 0.0) if top > 0 else np.zeros_like(r)
              for r, kp in zip(resp, keep)]
    peaks = []
    for k, (m, sc) in enumerate(zip(canvas.maps, scaled)):
        for i, j in zip(*np.nonzero(sc > threshold)):
            ij = _subpixel(smooth[k], i, j)
            pos = m.to_world(ij[None])[0]
            peaks.append(Peak(map_index=k, ij=ij, position=pos, normal=m.normal.copy(),
                              score=float(sc[i, j]), votes=float(smooth[k][i, j]),
                              kind=m.kind, plane=m.plane, room=m.room))
    peaks.sort(key=lambda p: -p.score)
    if max_peaks is not None:
        peaks = peaks[:max_peaks]
    return peaks, scaled

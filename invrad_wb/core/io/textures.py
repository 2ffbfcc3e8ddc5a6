"""UV illuminance textures: an image of lux (float) or of fractions of a white pixel's lux."""
import os

import numpy as np

from invrad_wb.errors import SceneError, SettingsError
from invrad_wb.core.io.common import _check_readable


# ====================================================================== textures
def read_lux_texture(path, max_lux=None):
    """Read an illuminance image as lux.

    Parameters
    ----------
    path : str or os.PathLike
        Any image OpenImageIO reads. Float images (EXR, HDR, float TIFF) hold lux; 8/16-bit
        images hold fractions of ``max_lux``.
    max_lux : float, optional
        Lux of a white (1.0) pixel; required for 8/16-bit images, refused for float ones.

    Returns
    -------
    (h, w) float64, lux
        Row 0 is the image's top row (v = 1). RGB is reduced to Rec.709 luminance, other
        images use their first channel; alpha below 0.5 and NaN pixels are no target
        (:mod:`invrad_wb.core.model.oiio`).
    """
    path = os.fspath(path)
    _check_readable(path)
    if max_lux is not None:
        try:
            ok = float(max_lux) > 0 and np.isfinite(float(max_lux))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise SettingsError(f"texture_max_lux must be a positive number, not {max_lux!r}")
    from invrad_wb.core.model.oiio import read_lux_image
    try:
        image = read_lux_image(path)
    except OSError as exc:
        raise SceneError(f"cannot read as an image: {exc}", path)
    lux, is_float = image.values, image.is_float
    if is_float and max_lux is not None:
        raise SceneError(f"a {image.format} image holds lux already: texture_max_lux applies"
                         " to 8/16-bit images only", path)
    if not is_float:
        if max_lux is None:
            raise SceneError(f"a {image.format} image holds no lux values: give"
                             " texture_max_lux, the lux of a white pixel (or use a float"
                             " EXR/HDR/TIFF holding lux)", path)
        lux = lux * float(max_lux)
    bad = np.isinf(lux) | (lux < 0)
    if bad.any():
        y, x = (int(a[0]) for a in np.nonzero(bad))
        kind = "infinite" if np.isinf(lux[y, x]) else "negative"
        raise SceneError(f"pixel (x={x}, y={y}) is {lux[y, x]} lx: illuminance cannot be"
                         f" {kind} (NaN = no target); {int(bad.sum())} such pixel(s)", path)
    return lux

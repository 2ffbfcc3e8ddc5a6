"""The one place that imports OpenImageIO, and the one image reader of invrad.

Illuminance images (UV textures of a scene, texture targets of the workbench) are read by
:func:`read_lux_image` with one rule for every caller: pixels as floats (8/16-bit images
give 0..1), a colour image reduced to its Rec. 709 luminance (channels named R, G, B, else
the first three that are not alpha), a grey image its first channel; pixels whose alpha is
below 0.5 are "no target" (NaN). The alpha channel is the one the file declares, else one
named A/alpha, else the last of a 2- or 4-channel image.
"""
from dataclasses import dataclass

import numpy as np

from invrad_wb.errors import InvradError

#: luminance weights of linear RGB (Rec. 709)
REC709 = np.array([0.2126, 0.7152, 0.0722])


def oiio_module(purpose="reading images"):
    """The OpenImageIO module, or one clear error naming the command that installs it."""
    try:
        import OpenImageIO as oiio
    except ImportError as exc:
        raise InvradError(f"{purpose} needs OpenImageIO (pip install OpenImageIO, or make"
                          f" setup in the checkout): {exc}") from None
    return oiio


@dataclass
class LuxImage:
    """An image read by :func:`read_lux_image`."""
    values: np.ndarray       # (h, w) float64, NaN where alpha < 0.5; row 0 = top row
    is_float: bool           # float pixels (EXR/HDR/TIFF): they hold lux themselves
    format: str


def _alpha_channel(spec, names):
    if spec.alpha_channel >= 0:
        return spec.alpha_channel
    for i, n in enumerate(names):
        if n in ("A", "ALPHA"):
            return i
    return spec.nchannels - 1 if spec.nchannels in (2, 4) else -1


def read_lux_image(path):
    """Read an image as one value per pixel (see the module docstring).

    Raises
    ------
    InvradError
        OpenImageIO missing; ValueError-like SceneError messages are the caller's: here a
        file that is not an image raises ``OSError`` with OpenImageIO's reason.
    """
    oiio = oiio_module("reading illuminance images")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(oiio.geterror() or "unknown image format")
    try:
        spec = inp.spec()
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
        error = inp.geterror() if pixels is None else ""
    finally:
        inp.close()
    if pixels is None or not spec.width or not spec.height:
        raise OSError(f"cannot read the image's pixels: {error or 'empty image'}")
    h, w, nc = spec.height, spec.width, spec.nchannels
    px = np.asarray(pixels, dtype=np.float64).reshape(h, w, nc)
    names = [str(n).upper() for n in spec.channelnames]
    a = _alpha_channel(spec, names)
    colour = [c for c in range(nc) if c != a]
    if all(c in names for c in "RGB"):
        rgb = [names.index(c) for c in "RGB"]
    else:
        rgb = colour[:3] if len(colour) >= 3 else None
    img = px[..., rgb] @ REC709 if rgb is not None else px[..., colour[0] if colour else 0]
    img = np.array(img, dtype=np.float64)
    if a >= 0:
        img[px[..., a] < 0.5] = np.nan
    is_float = spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
    return LuxImage(img, is_float, str(spec.format))

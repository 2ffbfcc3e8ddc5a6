"""The one place that imports OpenImageIO, and the one image reader of invrad.

:func:`read_pixels` reads any image as float pixels (8/16-bit images give 0..1); every
reader of image files goes through it (lux textures of a scene, texture targets of the
workbench, the report's images read back). Illuminance images are then reduced by
:func:`read_lux_image` with one rule for every caller: a colour image to its Rec. 709
luminance (channels named R, G, B, else the first three that are not alpha), a grey image
to its first channel; pixels whose alpha is below 0.5 are "no target" (NaN). The alpha
channel is the one the file declares, else one named A/alpha, else the last of a 2- or
4-channel image.
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
class Pixels:
    """An image file's pixels, as read by :func:`read_pixels`."""
    values: np.ndarray       # (h, w, c) float32; 8/16-bit images give 0..1; row 0 = top
    channel_names: list      # c str, upper case ("R", "G", "B", "A", "Y", ...)
    alpha: int               # index of the alpha channel, -1 if none
    is_float: bool           # float pixels (EXR/HDR/float TIFF)
    format: str              # the stored pixel type, e.g. "uint8", "half"


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


#: Peak bytes per pixel and channel while an image is read and converted (float32 from
#: OpenImageIO, a float64 copy), plus per pixel (the float64 lux image and its mask).
IMAGE_BYTES_PER_SAMPLE = 12
IMAGE_BYTES_PER_PIXEL = 24


def _require_image_memory(path, spec):
    """Refuse an image whose declared size would not fit in the memory budget (a small
    compressed file can declare 20000 x 20000 pixels)."""
    from invrad_wb.core.model.memory import require
    w, h, c = int(spec.width), int(spec.height), max(1, int(spec.nchannels))
    n = float(w) * float(h)
    require(n * (c * IMAGE_BYTES_PER_SAMPLE + IMAGE_BYTES_PER_PIXEL),
            f"{path}: its {w} x {h} pixels x {c} channel(s)", "use a smaller image")


def _error_of(obj):
    """``obj.geterror()``; OpenImageIO 3 (FreeCAD 1.0's root) raised UnicodeDecodeError
    from it for a corrupt EXR whose message quotes the file's bytes (fuzz test)."""
    try:
        return obj.geterror()
    except UnicodeDecodeError:
        return "corrupt file (OpenImageIO's message is not text)"


def _one_line(text):
    """OpenImageIO's error text (libpng and OpenEXR give several lines, often repeating)
    as one line: its distinct lines joined by '; '."""
    seen = []
    for line in str(text or "").splitlines():
        line = line.strip()
        if line and line not in seen:
            seen.append(line)
    return "; ".join(seen)


def read_pixels(path):
    """Read the first sub-image of an image file as float pixels.

    Parameters
    ----------
    path : str or os.PathLike
        Any image OpenImageIO reads (EXR, HDR, TIFF, PNG, JPEG, ...).

    Returns
    -------
    Pixels

    Raises
    ------
    InvradError
        If OpenImageIO is missing.
    OSError
        For a file that is not an image or cannot be read, with OpenImageIO's reason (the
        caller names the file).
    """
    oiio = oiio_module("reading images")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(_one_line(_error_of(oiio)) or "unknown image format")
    try:
        spec = inp.spec()
        _require_image_memory(path, spec)
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
        error = _error_of(inp) if pixels is None else ""
    finally:
        inp.close()
    if pixels is None or not spec.width or not spec.height:
        raise OSError(f"cannot read the image's pixels: {_one_line(error) or 'empty image'}")
    values = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width,
                                                          spec.nchannels)
    names = [str(n).upper() for n in spec.channelnames]
    is_float = spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
    return Pixels(values, names, _alpha_channel(spec, names), is_float, str(spec.format))


def read_lux_image(path):
    """Read an image as one value per pixel (see the module docstring).

    Returns
    -------
    LuxImage
        ``values (h, w) float64``: luminance or first channel, NaN where alpha < 0.5.

    Raises
    ------
    InvradError
        If OpenImageIO is missing.
    OSError
        For a file that is not an image, with OpenImageIO's reason (the caller names the
        file in its own error).
    """
    image = read_pixels(path)
    px, names, a = image.values.astype(np.float64), image.channel_names, image.alpha
    colour = [c for c in range(px.shape[2]) if c != a]
    if all(c in names for c in "RGB"):
        rgb = [names.index(c) for c in "RGB"]
    else:
        rgb = colour[:3] if len(colour) >= 3 else None
    img = px[..., rgb] @ REC709 if rgb is not None else px[..., colour[0] if colour else 0]
    img = np.array(img, dtype=np.float64)
    if a >= 0:
        img[px[..., a] < 0.5] = np.nan
    return LuxImage(img, image.is_float, image.format)

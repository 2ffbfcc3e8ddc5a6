"""The stored gather on OpenCL keeps the kernel's padded rows as they are read back
(form_factors.form_factor_rows_opencl): the same numbers as the point-to-patch form
factors computed on their own, however the rows are split into launches."""
import numpy as np
import pytest

from invrad_wb import constants as C
from invrad_wb.core.forward import form_factors as ff
from invrad_wb.core.forward import radiosity as R
from invrad_wb.core.synthetic import generate


@pytest.mark.opencl
@pytest.mark.parametrize("chunk_mb", [64, 0])       # 0: one receiver row per launch
def test_stored_gather_is_the_form_factors_bit_for_bit(monkeypatch, chunk_mb):
    scene = generate.pillar_room()
    model = R.RadiosityModel(scene, backend="opencl", patch_size=0.5)
    room = model.rooms[0]
    assert room.vis is not None and room.patches.n % ff.PATCH_LANES != 0   # padded rows
    pts, nrm = model.vertex_receivers()
    keep = model.vertex_patch >= 0
    want = model._form_factors(room, pts[keep], nrm[keep], model.vertex_patch[keep])
    monkeypatch.setattr(C, "RADIOSITY_CL_CHUNK_MB", chunk_mb)
    op = model.gather(pts, nrm, model.vertex_patch)
    mat = op._blocks[0][2]
    assert mat.dtype == np.float32 and mat.shape == want.shape
    assert np.array_equal(mat, want)
    b = np.random.default_rng(0).uniform(0, 50, model.n_patches)
    assert np.array_equal(op(b)[keep], np.ascontiguousarray(mat) @ b.astype(np.float32))


def test_rows_buffer_of_the_wrong_shape_is_refused():
    scene = generate.box_room(size=(3.0, 3.0, 3.0), cell=0.5)
    try:
        model = R.RadiosityModel(scene, backend="opencl", patch_size=0.7)
    except Exception as exc:                 # no device: nothing to check
        pytest.skip(str(exc))
    room = model.rooms[0]
    pts = room.patches.point[:4]
    local = np.arange(4)
    with pytest.raises(ValueError, match="C-contiguous"):
        ff.form_factor_rows_opencl(pts, room.patches.normal[:4], room.patches.plane[local],
                                   room.patches, local, room.vis, room.centre,
                                   np.empty((4, ff.padded_patches(room.patches.n) + 16),
                                            np.float32))

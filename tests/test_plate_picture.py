"""The plate as the report and the docs draw it (docs/model.md section 10): which masses of column 1's face the
load pushes, the same as the numpy reference's weights; the report's lattice picture of a plate shows its layers
as a stack, the loaded patch and the backplate, while a one-layer lattice keeps its picture; the explore page's
data of a plate carries its depth and patch."""
from __future__ import annotations

import numpy as np
import pytest

from fmu_src.variables import loaded_face
from reference.lattice3d import load_weights


def test_a_3x3_patch_on_an_11x11_face_is_its_nine_middle_masses():
    face = loaded_face(11, 11, 3)
    assert not face.whole_face
    assert face.masses() == {(i, k) for i in (4, 5, 6) for k in (4, 5, 6)}


def test_load_patch_0_is_the_whole_face():
    face = loaded_face(11, 5, 0)
    assert face.whole_face and len(face.masses()) == 55
    assert face.row_range == range(11) and face.depth_range == range(5)


@pytest.mark.parametrize("rows, depth, patch", [(11, 11, 3), (11, 5, 5), (5, 5, 1), (7, 3, 3), (11, 11, 0),
                                                (4, 6, 0)])
def test_the_loaded_masses_are_those_the_reference_loads(rows, depth, patch):
    """The independent numpy model (reference/lattice3d.py) puts weight on exactly these masses."""
    weights = load_weights(rows, depth, patch)  # (depth, rows)
    loaded = {(i, k) for k in range(depth) for i in range(rows) if weights[k, i] > 0}
    assert loaded_face(rows, depth, patch).masses() == loaded


@pytest.mark.parametrize("rows, depth, patch", [(11, 11, 2), (11, 11, 4), (11, 5, 7), (10, 11, 3), (11, 4, 1),
                                                (11, 11, -1), (11, 11, True), (11, 11, 3.0)])
def test_a_patch_the_model_cannot_centre_is_refused_in_one_line(rows, depth, patch):
    with pytest.raises(ValueError) as error:
        loaded_face(rows, depth, patch)
    message = str(error.value)
    assert message.startswith(f"load_patch = {patch!r} is not allowed") and "\n" not in message
    assert "0 (the whole face) or an odd P" in message

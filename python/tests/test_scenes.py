# Scenes from every source the CLI reads, and their cameras and lights.
import os

import numpy as np
import pytest

import coneshadow


def test_builtin(builtin):
    assert builtin.name == "builtin" and builtin.triangle_count > 1000
    assert [c.name for c in builtin.cameras] == ["wall", "fur", "room", "ceiling", "edge"]
    assert len(builtin.lights) >= 1
    assert builtin.positions.shape == (builtin.vertex_count, 3) and builtin.positions.dtype == np.float32
    assert builtin.indices.shape == (builtin.triangle_count, 3) and builtin.indices.dtype == np.uint32
    assert coneshadow.Scene.load("builtin").triangle_count == builtin.triangle_count


def test_heightfield():
    s = coneshadow.Scene.load("heightfield:2k")
    assert 1500 < s.triangle_count < 2500 and len(s.lights) == 1 and not s.cameras


def test_from_arrays_round_trip():
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    indices = np.array([[0, 1, 2]], np.uint32)
    cam = coneshadow.Camera((0, 0, 3), (0, 0, 0), name="front")
    s = coneshadow.Scene.from_arrays(positions, indices, lights=[[0, 0, 2], [1, 1, 1]], cameras=[cam])
    np.testing.assert_array_equal(s.positions, positions[indices].reshape(-1, 3))  # flat: a triangle's own vertices
    np.testing.assert_array_equal(s.indices, [[0, 1, 2]])
    smooth = coneshadow.Scene.from_arrays(positions, indices, normals=np.tile(np.float32([0, 0, 2]), (3, 1)))
    np.testing.assert_array_equal(smooth.positions, positions)
    assert [l.position for l in s.lights] == [(0, 0, 2), (1, 1, 1)]
    assert s.cameras[0].name == "front" and s.cameras[0].eye == (0, 0, 3)
    assert s.bounds == ((0, 0, 0), (1, 1, 0))


GLB = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"


@pytest.mark.skipif(not os.path.exists(GLB), reason="assimp-testmodels not installed")
def test_load_a_file():
    s = coneshadow.Scene.load(GLB, ground_plane=True)
    assert s.path == GLB and s.triangle_count == 12 + 2

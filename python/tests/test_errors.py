# Usage errors are ValueError (naming the expected dtype and shape), scene and device errors RuntimeError,
# each with the CLI's one-line message.
import numpy as np
import pytest

import coneshadow

P = np.zeros((4, 3), np.float32)
N = np.tile(np.float32([0, 1, 0]), (4, 1))


@pytest.fixture(scope="module")
def quad():
    positions = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    return coneshadow.Scene.from_arrays(positions, np.array([[0, 1, 2], [0, 2, 3]], np.uint32))


@pytest.mark.parametrize("points, expected", [
    (P.astype(np.float64), r"points: expected a float32 array of shape \(N, 3\), got float64 array of shape \(4, 3\)"),
    (P[:, :2], r"shape \(N, 3\), got float32 array of shape \(4, 2\)"),
    (P.tolist(), r"shape \(N, 3\), got list"),
    (P[:0], r"at least one sample"),
    (np.full((4, 3), np.nan, np.float32), r"sample 0 is not finite"),
])
def test_bad_points(quad, points, expected):
    with pytest.raises(ValueError, match=expected):
        coneshadow.visibility(quad, points, N[:len(points)] if len(points) else N[:0], (0, 2, 0))


def test_bad_normals_and_lights(quad):
    with pytest.raises(ValueError, match=r"normals: .*N = 4 of points, got \(3, 3\)"):
        coneshadow.visibility(quad, P, N[:3], (0, 2, 0))
    with pytest.raises(ValueError, match=r"normal 0 is zero"):
        coneshadow.visibility(quad, P, np.zeros((4, 3), np.float32), (0, 2, 0))
    with pytest.raises(ValueError, match=r"lights: expected one light \(x, y, z\) or several, shape \(L, 3\)"):
        coneshadow.visibility(quad, P, N, [[0, 1], [2, 3]])
    with pytest.raises(ValueError, match=r"lights: light 0 is not three finite numbers"):
        coneshadow.visibility(quad, P, N, (0, np.inf, 0))
    with pytest.raises(ValueError, match=r"lights: light 0: "):
        coneshadow.visibility(quad, P, N, (0, 1e30, 0))


def test_bad_arrays():
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    with pytest.raises(ValueError, match=r"indices: expected a uint32 array of shape \(M, 3\), got int64 array"):
        coneshadow.Scene.from_arrays(tri, np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match=r"positions: expected a float32 array of shape \(N, 3\), got float32 array of shape \(9,\)"):
        coneshadow.Scene.from_arrays(tri.ravel(), np.array([[0, 1, 2]], np.uint32))
    with pytest.raises(ValueError, match=r"triangle 0 names vertex 3, past the 3 positions"):
        coneshadow.Scene.from_arrays(tri, np.array([[0, 1, 3]], np.uint32))
    with pytest.raises(ValueError, match=r"at least one triangle"):
        coneshadow.Scene.from_arrays(tri, np.zeros((0, 3), np.uint32))


def test_bad_cameras():
    with pytest.raises(ValueError, match=r"yfov"):
        coneshadow.Camera((0, 0, 5), (0, 0, 0), yfov=4.0)
    with pytest.raises(ValueError, match=r"target equals eye"):
        coneshadow.Camera((0, 0, 5), (0, 0, 5))
    with pytest.raises(ValueError, match=r"parallel to the view"):
        coneshadow.Camera((0, 5, 0), (0, 0, 0), up=(0, 1, 0))
    with pytest.raises(ValueError, match=r"Camera eye: expected three numbers"):
        coneshadow.Camera((0, 5), (0, 0, 0))


def test_bad_frames(builtin):
    with pytest.raises(ValueError, match=r"unknown method 'cnoe'.*did you mean"):
        coneshadow.render(builtin, methods=["cnoe"])
    with pytest.raises(ValueError, match=r"no method takes a setting 'no-such-setting'"):
        coneshadow.render(builtin, methods=["cone"], settings={"no-such-setting": 1})
    with pytest.raises(ValueError, match=r"'sm-resolution' is a setting of .*which this run does not use"):
        coneshadow.render(builtin, methods=["cone"], settings={"sm-resolution": 1024})
    with pytest.raises(ValueError, match=r"sm-resolution"):
        coneshadow.render(builtin, methods=["cubesm"], settings={"sm-resolution": "lots"})
    with pytest.raises(ValueError, match=r"width: expected 1 to 16384 pixels, got 0"):
        coneshadow.render(builtin, width=0)
    with pytest.raises(ValueError, match=r"has no view 'nowhere' \(views: "):
        coneshadow.render(builtin, camera="nowhere")
    with pytest.raises(ValueError, match=r"methods: the list names no method"):
        coneshadow.render(builtin, methods=[])
    with pytest.raises(ValueError, match=r"lights: expected one light \(x, y, z\), several \(L, 3\), 'all' or None"):
        coneshadow.render(builtin, lights="every")
    with pytest.raises(ValueError, match=r"lights='all': scene arrays has no point light"):
        tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
        cam = coneshadow.Camera((0, 0, 3), (0, 0, 0))
        coneshadow.render(coneshadow.Scene.from_arrays(tri, np.array([[0, 1, 2]], np.uint32), cameras=[cam]), lights="all")


def test_scene_errors(tmp_path):
    with pytest.raises(RuntimeError, match=r"no such file"):
        coneshadow.Scene.load(str(tmp_path / "missing.gltf"))
    bad = tmp_path / "bad.gltf"
    bad.write_text("{ not json")
    with pytest.raises(RuntimeError, match=r"bad.gltf"):
        coneshadow.Scene.load(str(bad))
    with pytest.raises(ValueError, match=r"heightfield"):
        coneshadow.Scene.load("heightfield:x")

# visibility() on samples of the caller's own, and a two-triangle scene whose shadow is known in closed
# form (through visibility() and through render()).
import numpy as np
import pytest

import coneshadow

# A receiver triangle on y = 0 and an occluder triangle on y = 1 under a light at y = 3: the occluder's
# shadow on the receiver is the occluder scaled by 3 / (3 - 1) about the light's foot, (0, 0, 0).
LIGHT = (0.0, 3.0, 0.0)
OCCLUDER = np.array([[-0.5, 1, -0.5], [0.5, 1, -0.5], [0.0, 1, 0.5]], np.float32)
SHADOW = OCCLUDER[:, [0, 2]] * 1.5  # its (x, z) corners on y = 0


def two_triangles():
    receiver = np.array([[-8, 0, -4], [8, 0, -4], [0, 0, 8]], np.float32)
    positions = np.concatenate([receiver, OCCLUDER])
    return coneshadow.Scene.from_arrays(positions, np.array([[0, 1, 2], [3, 4, 5]], np.uint32), lights=LIGHT)


def signed_distances(xz):
    """Each point's distance inside (> 0) the shadow triangle's edges, the smallest of the three."""
    d = []
    for k in range(3):
        a, b = SHADOW[k], SHADOW[(k + 1) % 3]
        n = np.array([-(b - a)[1], (b - a)[0]])
        n /= np.linalg.norm(n)
        centre = SHADOW.mean(axis=0)
        s = np.sign((centre - a) @ n)
        d.append(s * ((xz - a) @ n))
    return np.min(d, axis=0)


def test_the_two_triangle_shadow_in_closed_form():
    scene = two_triangles()
    assert scene.triangle_count == 2 and scene.lights[0].position == LIGHT
    g = np.linspace(-1.2, 1.2, 121, dtype=np.float32)
    x, z = np.meshgrid(g, g)
    xz = np.stack([x.ravel(), z.ravel()], axis=1)
    points = np.stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]], axis=1).astype(np.float32)
    normals = np.tile(np.float32([0, 1, 0]), (len(points), 1))
    visible = coneshadow.visibility(scene, points, normals, LIGHT)
    assert visible.shape == (1, len(points)) and visible.dtype == np.bool_
    inside = signed_distances(xz)
    clear = np.abs(inside) > 1e-3  # off the shadow's edges
    np.testing.assert_array_equal(visible[0][clear], inside[clear] < 0)
    assert (~visible[0]).sum() > 1000  # the shadow is there
    # The same samples facing down are not visible (they face away from the light).
    assert not coneshadow.visibility(scene, points, -normals, LIGHT).any()


def test_the_two_triangle_shadow_rendered():
    scene = two_triangles()
    camera = coneshadow.Camera(eye=(0, 2.5, 0.01), target=(0, 0, 0), up=(0, 0, -1), yfov=1.2)
    frame = coneshadow.render(scene, camera=camera, methods=["cone", "cubesm"], width=96, height=96, frames=1)
    on_receiver = frame.lit & (np.abs(frame.position[..., 1]) < 1e-4)
    inside = signed_distances(frame.position[..., [0, 2]].reshape(-1, 2)).reshape(96, 96)
    clear = on_receiver & (np.abs(inside) > 0.02)
    assert clear.sum() > 2000
    for name in ("embree", "cone"):
        lit = frame.visibility[name] >= 0.5
        np.testing.assert_array_equal(lit[clear], inside[clear] < 0, err_msg=name)
    assert frame.results["cone"]["error"]["misclassified_outside_band"] == 0


def test_random_samples_against_embree(builtin):
    rng = np.random.default_rng(7)
    lo, hi = map(np.array, builtin.bounds)
    n = 20000
    points = (lo + (hi - lo) * rng.random((n, 3))).astype(np.float32)
    normals = rng.normal(size=(n, 3)).astype(np.float32)
    lights = np.array([lo + (hi - lo) * f for f in ([0.5, 0.85, 0.5], [0.2, 0.6, 0.7], [0.8, 0.4, 0.3])])
    visible, reference, band = coneshadow.visibility(builtin, points, normals, lights, reference=True)
    assert visible.shape == reference.shape == band.shape == (3, n)
    outside = ~band
    assert (visible != reference)[outside].sum() == 0
    for l in range(3):  # both answers are there, on every light
        assert 0 < visible[l].sum() < n and (~visible[l] & outside[l]).sum() > 0
    assert band.sum() < 0.05 * n
    # The answer without the reference is the same, and does not depend on the lights called together.
    np.testing.assert_array_equal(coneshadow.visibility(builtin, points, normals, lights[1]), visible[1:2])
    # Embree's threads flush denormals to zero; the calling thread's (numpy's) mode stays its own.
    assert np.float64(1e-310) * np.float64(1.0) != 0.0

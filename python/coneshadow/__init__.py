"""coneshadow from Python: alias-free hard shadows from point lights, judged against Embree.

Numpy in, numpy out, on the same code as the ``coneshadow`` CLI:

* :class:`Scene` -- ``Scene.load(path)`` (every format the CLI reads, ``'heightfield:N'`` too),
  ``Scene.from_arrays(positions, indices)``, ``Scene.builtin()``; its ``cameras`` and ``lights``;
  :class:`Camera` ``(eye, target, up, yfov)``.
* :func:`visibility` -- the exact shadow visibility of samples of your own (points and normals from any
  renderer) through the cone path on the device, optionally with Embree's answer and the ambiguity band.

Errors: a wrong argument (type, dtype, shape, value, an unknown method or setting) raises ``ValueError``;
a scene that cannot be read or a device that fails raises ``RuntimeError``; each carries the CLI's
one-line message. The GIL is released while the device and Embree work. The Vulkan device is chosen
automatically as the CLI does (:func:`set_device` picks another).
"""

import atexit as _atexit

from . import _coneshadow
from ._coneshadow import Camera, Light, Scene, device, devices, methods, set_device

__all__ = ["Camera", "Light", "Scene", "visibility", "device", "devices", "methods", "set_device"]

_atexit.register(_coneshadow._release_device)  # the Vulkan context ends before the loader unloads


def visibility(scene, points, normals, lights, reference=False):
    """The exact shadow visibility of your own samples from each light, on the device through the cone path.

    Args:
        scene: a :class:`Scene` (its triangles are the occluders; its lights are not used).
        points: float32 (N, 3), the samples' world positions.
        normals: float32 (N, 3), their normals (one-sided: the side you shade; scaled to unit length).
        lights: one point light (x, y, z) or several, shape (L, 3).
        reference: also trace the same samples with Embree, and the ambiguity band.

    Returns:
        bool (L, N): True where the sample faces the light (N.L > 0, the light term the engine computes)
        and no triangle lies between, under the scene's epsilon policy. A sample facing away from a light
        is False. With ``reference=True``, a tuple ``(visible, reference, band)`` of three bool (L, N)
        arrays: Embree's answer by the same rule, and the band where no answer is wrong (the cone path
        agrees with Embree on every sample outside it).
    """
    return _coneshadow._visibility(scene, points, normals, lights, reference)

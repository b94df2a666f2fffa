"""coneshadow from Python: alias-free hard shadows from point lights, judged against Embree.

Numpy in, numpy out, on the same code as the ``coneshadow`` CLI:

* :class:`Scene` -- ``Scene.load(path)`` (every format the CLI reads, ``'heightfield:N'`` too),
  ``Scene.from_arrays(positions, indices)``, ``Scene.builtin()``; its ``cameras`` and ``lights``;
  :class:`Camera` ``(eye, target, up, yfov)``.

Errors: a wrong argument (type, dtype, shape, value, an unknown method or setting) raises ``ValueError``;
a scene that cannot be read or a device that fails raises ``RuntimeError``; each carries the CLI's
one-line message. The GIL is released while the device and Embree work. The Vulkan device is chosen
automatically as the CLI does (:func:`set_device` picks another).
"""

import atexit as _atexit

from . import _coneshadow
from ._coneshadow import Camera, Light, Scene, device, devices, methods, set_device

__all__ = ["Camera", "Light", "Scene", "device", "devices", "methods", "set_device"]

_atexit.register(_coneshadow._release_device)  # the Vulkan context ends before the loader unloads

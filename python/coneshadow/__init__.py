"""coneshadow from Python: alias-free hard shadows from point lights, judged against Embree.

Numpy in, numpy out, on the same code as the ``coneshadow`` CLI:

* :class:`Scene` -- ``Scene.load(path)`` (every format the CLI reads, ``'heightfield:N'`` too),
  ``Scene.from_arrays(positions, indices)``, ``Scene.builtin()``; its ``cameras`` and ``lights``;
  :class:`Camera` ``(eye, target, up, yfov)``.
* :func:`render` -- one view under one or more lights, every chosen method judged against Embree: the
  masks, the rows of the CLI's ``results.json`` (error counts, stages, stats) and the frame's samples.
* :func:`compare` -- the rows the CLI's ``compare`` writes (each method's sweep), as a list of dicts.
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

__all__ = ["Camera", "Light", "Scene", "Frame", "render", "compare", "visibility", "device", "devices", "methods",
           "set_device"]

_atexit.register(_coneshadow._release_device)  # the Vulkan context ends before the loader unloads


class Frame:
    """The result of :func:`render`: one view under one light, or under several.

    With one light, each per-light array is (H, W) and each per-light list of rows is a plain dict; with
    several lights (``lights`` of shape (L, 3), or ``'all'``), they gain a leading axis of length L
    (arrays (L, H, W), rows lists of L dicts), in the order the lights were given.

    Attributes:
        visibility: dict method -> float32 (H, W) or (L, H, W): 1 lit, 0 shadowed, in between where a
            method filters; 1 where the sample is not lit (no geometry, or facing away from the light).
            Always holds the reference (``'embree'``).
        results: dict method -> the method's row of the CLI's results.json (dict: ``error``, ``stages``,
            ``stats``, ``total_ms``, ``bytes``, ``provenance``, ...), or a list of them, one per light.
        rows: every row, as results.json lists them (per light: the reference first, then each method).
        position: float32 (H, W, 3), the samples' world positions; NaN where the pixel has no geometry.
        normal: float32 (H, W, 3), the unit normals, turned toward the camera; NaN without geometry.
        lit: bool (H, W) or (L, H, W): the sample has geometry and faces the light (what the metric counts).
        reference: float32 (H, W) or (L, H, W): Embree's visibility (the same as ``visibility['embree']``).
        band: bool (H, W) or (L, H, W): the ambiguity band, where no answer is wrong.
        lights: float32 (L, 3), the lights as rendered; camera: the :class:`Camera`; view: its name;
        device: the Vulkan device.
    """

    def __init__(self, raw, several):
        self._several = several
        pick = (lambda a: a) if several else (lambda a: a[0])
        self.device = raw["device"]
        self.camera = raw["camera"]
        self.view = raw["view"]
        self.lights = raw["lights"]
        self.visibility = {name: pick(a) for name, a in raw["visibility"].items()}
        per_light = raw["rows"]
        self.rows = [row for light in per_light for row in light]
        names = [row["method"] for row in per_light[0]]
        self.results = {name: pick([light[k] for light in per_light]) for k, name in enumerate(names)}
        self.position = raw["position"]
        self.normal = raw["normal"]
        self.lit = pick(raw["lit"])
        self.reference = pick(raw["reference"])
        self.band = pick(raw["band"])

    @property
    def methods(self):
        """The methods of the frame, the reference first."""
        return list(self.results)

    def error(self, method):
        """The method's error counts (results.json's ``error``), or a list of them, one per light."""
        r = self.results[method]
        return [x["error"] for x in r] if self._several else r["error"]

    def __repr__(self):
        h, w = self.position.shape[:2]
        return "<coneshadow.Frame %s %dx%d, %d light(s), methods %s on %s>" % (
            self.view, w, h, len(self.lights), ", ".join(self.methods), self.device)


def _several(lights):
    if lights is None:
        return False
    if isinstance(lights, str):
        return True  # 'all'
    try:
        import numpy as np
        return np.ndim(lights) == 2
    except Exception:  # the extension names what is wrong with it
        return False


def render(scene, camera=None, lights=None, width=512, height=512, methods=None, settings=None, frames=3):
    """One view of ``scene`` under each light, every method judged against Embree (the CLI's render).

    Args:
        scene: a :class:`Scene`.
        camera: a :class:`Camera`, a view name of the scene, or None: the scene's first camera, else an
            automatic one (a warning), as the CLI.
        lights: one point light (x, y, z) or several, shape (L, 3), each a frame (the CLI's --light given
            several times); ``'all'``: every point light of the scene (--all-lights); None: the scene's
            first point light, else an automatic one (a warning), as the CLI.
        width, height: the camera pass's size (1 to 16384).
        methods: a method name or a list of them (:func:`methods`); None: the reference alone, as the CLI's
            render. The reference (``'embree'``) is always the first row.
        settings: the methods' settings as the CLI's flags without the dashes, e.g.
            ``{'sm-resolution': 2048, 'memory-budget': '64M'}``; a switch takes True; True/False elsewhere
            mean on/off. A setting no chosen method takes is a ValueError, as on the command line.
        frames: timed frames after one warm-up (1 to 1000); times are their median.

    Returns:
        a :class:`Frame`: for the same frame, its rows hold the keys and the numbers of the CLI's
        ``results.json`` (the times are this run's).
    """
    raw = _coneshadow._render(scene, camera, lights, width, height, methods, settings, frames)
    return Frame(raw, _several(lights))


def compare(scene, views=None, lights=None, width=256, height=256, methods=None, settings=None, frames=3,
            interleave=False, out=None):
    """Every chosen method's sweep (the CLI's compare) on each view under each light, against Embree.

    Args:
        scene: a :class:`Scene`.
        views: a list of :class:`Camera` or view names; None: every camera of the scene, else an automatic one.
        lights: as in :func:`render`.
        width, height: the camera pass's size (compare's default 256 x 256).
        methods: method names; None: every registered method.
        settings: as in :func:`render`; each method's sweep is taken around them.
        frames: timed frames after one warm-up.
        interleave: the methods' timed frames round-robin (the CLI's --interleave).
        out: a folder to write results.json and results.csv into (the CLI's report and images are the
            CLI's: ``coneshadow compare --out``); None writes nothing.

    Returns:
        the rows of the CLI's results.json, a list of dicts (view by view, each light, each sweep point;
        ``stats['setting']`` names the point). Sweep points the device cannot run are skipped with a warning.
    """
    return _coneshadow._compare(scene, views, lights, width, height, methods, settings, frames, interleave,
                                None if out is None else str(out))


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

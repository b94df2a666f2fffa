#!/usr/bin/env python3
"""Sweeps a point light's distance and plots every method's error and time against it (matplotlib).

The light moves out from the scene's centre toward the scene's own light (up, without one) to D scene
diagonals (as the CLI's ``compare --light-distances``); at each distance one frame judges every method
against Embree on the same samples. Far lights are where shadow maps lose resolution (the scene shrinks
to a few texels of their faces) and the cone path stays exact.

    PYTHONPATH=build/python python3 examples/python/light_distances.py [--scene FILE] [--size 256]
        [--distances 1,10,100,1000,10000,100000] [--methods cone,cubesm,rmsm,asm,rtw] [--out light_distances.png]

The default scene is assimp's 2CylinderEngine (assimp-testmodels, as docs/RESULTS.md's light sweep), else
the built-in one.
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import coneshadow  # noqa: E402


ENGINE = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=ENGINE if os.path.exists(ENGINE) else "builtin",
                    help="a scene file, 'builtin' or 'heightfield:N'")
    ap.add_argument("--size", type=int, default=256, help="the camera pass's width and height")
    ap.add_argument("--distances", default="1,10,100,1000,10000,100000", help="light distances, in scene diagonals")
    ap.add_argument("--methods", default=None, help="methods (default: every one but the reference)")
    ap.add_argument("--frames", type=int, default=3, help="timed frames a point (the median is plotted)")
    ap.add_argument("--out", default="light_distances.png", help="the figure (PNG)")
    a = ap.parse_args()

    scene = coneshadow.Scene.load(a.scene)
    methods = a.methods.split(",") if a.methods else [m for m in coneshadow.methods() if m != "embree"]
    lo, hi = map(np.array, scene.bounds)
    centre = (lo + hi) / 2
    own = np.array(scene.lights[0].position) if scene.lights else centre + [0.3, 1.0, 0.2]
    away = (own - centre) / np.linalg.norm(own - centre)
    distances = [float(d) for d in a.distances.split(",")]

    times = {m: [] for m in methods}
    errors = {m: [] for m in methods}
    for d in distances:
        light = centre + d * scene.diagonal * away
        frame = coneshadow.render(scene, lights=light, width=a.size, height=a.size, methods=methods,
                                  frames=a.frames)
        line = []
        for m in methods:
            row = frame.results[m]
            times[m].append(row["total_ms"])
            errors[m].append(100 * row["error"]["misclassified_fraction_outside_band"])
            line.append("%s %.1f ms %.4f %%" % (m, times[m][-1], errors[m][-1]))
        band = 100 * frame.results[methods[0]]["error"]["band_fraction"]
        print("%8g diagonals (band %.2f %%): %s" % (d, band, ", ".join(line)), flush=True)

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    for m in methods:
        top.plot(distances, times[m], marker="o", label=m)
        # Exact frames (0 misclassified) sit on the floor of the log axis.
        bottom.plot(distances, np.maximum(errors[m], 1e-4), marker="o", label=m)
    top.set(xscale="log", yscale="log", ylabel="shadow time, ms (median)",
            title="%s, %d² on %s" % (scene.name, a.size, coneshadow.device().split(" (")[0]))
    bottom.set(xscale="log", yscale="log", ylabel="misclassified outside the band, %\n(floor: exact)",
               xlabel="light distance from the scene's centre, scene diagonals")
    for ax in (top, bottom):
        ax.grid(True, which="both", alpha=0.3)
    top.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(a.out, dpi=100)
    print("wrote", a.out)


if __name__ == "__main__":
    main()

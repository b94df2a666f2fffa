#!/usr/bin/env python3
"""The Python module's overhead: a cone frame from Python (coneshadow.render) against the CLI's.

Both time the same harness (the frame's shadow work, the row's total_ms, median of --frames, and its
fastest frame, total_ms_min), so their frame times should agree within the machine's noise; the call's wall time adds what each pays around the
frame (Python: the arrays; the CLI: process start, the scene, the images and results written). The runs
alternate, --rounds of each, each first every other round, so a slow spell of a shared machine falls on both.

    PYTHONPATH=build/python python3 bench/python_overhead.py [--size 512] [--frames 5] [--rounds 3]
        [--cli build/app/coneshadow] [--scene builtin] [--view wall]
"""
import argparse
import json
import pathlib
import statistics
import subprocess
import tempfile
import time

import coneshadow


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cli", default=str(pathlib.Path(__file__).resolve().parents[1] / "build" / "app" / "coneshadow"))
    ap.add_argument("--scene", default="builtin")
    ap.add_argument("--view", default="wall")
    a = ap.parse_args()

    scene = coneshadow.Scene.load(a.scene)
    py_frame, py_wall, cli_frame, cli_wall = [], [], [], []
    py_min, cli_min = [], []
    with tempfile.TemporaryDirectory() as tmp:
        def python_frame():
            t = time.perf_counter()
            f = coneshadow.render(scene, camera=a.view, width=a.size, height=a.size, methods=["cone"], frames=a.frames)
            py_wall.append(1e3 * (time.perf_counter() - t))
            py_frame.append(f.results["cone"]["total_ms"])
            py_min.append(f.results["cone"]["stats"]["total_ms_min"])

        def cli_frame_(r):
            out = pathlib.Path(tmp) / ("out%d" % r)
            t = time.perf_counter()
            subprocess.run([a.cli, "render", a.scene, "--view", a.view, "--methods", "cone", "--width", str(a.size),
                            "--height", str(a.size), "--frames", str(a.frames), "--quiet", "--out", str(out)],
                           check=True, stdout=subprocess.DEVNULL)
            cli_wall.append(1e3 * (time.perf_counter() - t))
            rows = json.loads((out / "results.json").read_text())
            cone = next(x for x in rows if x["method"] == "cone")
            cli_frame.append(cone["total_ms"])
            cli_min.append(cone["stats"]["total_ms_min"])

        for r in range(a.rounds):  # each goes first every other round
            if r % 2 == 0:
                python_frame()
                cli_frame_(r)
            else:
                cli_frame_(r)
                python_frame()
            print("round %d: cone frame %.2f ms (Python) / %.2f ms (CLI); call %.0f / %.0f ms"
                  % (r + 1, py_frame[-1], cli_frame[-1], py_wall[-1], cli_wall[-1]), flush=True)

    pf, cf = statistics.median(py_frame), statistics.median(cli_frame)
    pw, cw = statistics.median(py_wall), statistics.median(cli_wall)
    print("| %d² cone frame, %s | Python | CLI | Python / CLI |" % (a.size, coneshadow.device().split(" (")[0]))
    print("| --- | ---: | ---: | ---: |")
    print("| frame, ms (median of %d rounds of %d frames) | %.2f | %.2f | %.3f |" % (a.rounds, a.frames, pf, cf, pf / cf))
    pm, cm = min(py_min), min(cli_min)
    print("| frame, ms (fastest of all) | %.2f | %.2f | %.3f |" % (pm, cm, pm / cm))
    print("| the call, ms (wall) | %.0f | %.0f | %.3f |" % (pw, cw, pw / cw))


if __name__ == "__main__":
    main()

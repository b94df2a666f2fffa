#!/usr/bin/env python3
"""The cone path through `coneshadow render` with N lights against N renders of one light each
(docs/RESULTS.md, "Several lights a frame"). For each view and N, rounds alternate one render of the N
lights (the method takes them together: one submission) and the N one-light renders; a render's cone
time is the sum of its lights' total_ms (each the median of --frames; with several lights a light's
share of the frame). The medians over the rounds, and their ratio. The lights: the scene's first point
light, then points over the upper half of its bounds (bench/lights_bench.cpp's).

  bench/render_lights_bench.py [--cli build/app/coneshadow] [--size 256] [--frames 5] [--rounds 3]
                               [--lights 1,2,4,8] [--views builtin:wall,PATH/museum5.aff:view]
Prints a markdown table.
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

OFFSETS = [(0.3, 0.35, 0.2), (-0.3, 0.4, 0.1), (0.1, 0.45, -0.3), (-0.2, 0.3, -0.25), (0.0, 0.2, 0.0),
           (0.35, 0.1, 0.35), (-0.35, 0.25, 0.3)]


def vec(text):
    return [float(v) for v in text.split(",")]


def lights_of(cli, scene):
    out = subprocess.run([cli, "info", scene], capture_output=True, text=True, check=True).stdout
    bounds = re.search(r"bounds: min (\S+)\s+max (\S+)", out)
    first = re.search(r"position (\S+)", out)
    if not bounds or not first:
        sys.exit(f"render_lights_bench: {scene}: no bounds or point light in `coneshadow info`")
    lo, hi = vec(bounds.group(1)), vec(bounds.group(2))
    lights = [vec(first.group(1))]
    for o in OFFSETS:
        lights.append([(lo[i] + hi[i]) / 2 + o[i] * (hi[i] - lo[i]) for i in range(3)])
    return lights


def cone_ms(cli, scene, view, lights, args, out):
    cmd = [cli, "render", scene, "--methods", "cone", "--view", view, "--width", str(args.size), "--height",
           str(args.size), "--frames", str(args.frames), "--quiet", "--out", out]
    for l in lights:
        cmd += ["--light", ",".join(f"{v:.6g}" for v in l)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"render_lights_bench: {' '.join(cmd)}\n{run.stdout}{run.stderr}")
    with open(os.path.join(out, "results.json")) as f:
        rows = [r for r in json.load(f) if r["method"] == "cone"]
    return sum(r["total_ms"] for r in rows)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--cli", default="build/app/coneshadow")
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--frames", type=int, default=5)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--lights", default="1,2,4,8")
    p.add_argument("--views", default="builtin:wall,../shared/scenes/bart/museum/museum5.aff:view")
    args = p.parse_args()
    print("| view | lights | one render of N lights: cone ms | N one-light renders: cone ms | ratio "
          "| per further light, ms |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        for spec in args.views.split(","):
            scene, view = spec.rsplit(":", 1)
            everyone = lights_of(args.cli, scene)
            one = None
            for n in (int(v) for v in args.lights.split(",")):
                lights = everyone[:n]
                together, apart = [], []
                for _ in range(args.rounds):
                    together.append(cone_ms(args.cli, scene, view, lights, args, os.path.join(tmp, "n")))
                    apart.append(sum(cone_ms(args.cli, scene, view, [l], args, os.path.join(tmp, "1"))
                                     for l in lights))
                t, a = statistics.median(together), statistics.median(apart)
                if n == 1:
                    one = t
                further = f"{(t - one) / (n - 1):.1f}" if n > 1 and one is not None else ""
                name = os.path.splitext(os.path.basename(scene))[0]
                print(f"| {name}/{view} | {n} | {t:.1f} | {a:.1f} | {t / a:.2f} | {further} |", flush=True)


if __name__ == "__main__":
    main()

# render() and compare() against the CLI on the same frame: the same rows (keys and numbers of
# results.json, the times aside), the same masks, and the same samples.
import json
import subprocess

import numpy as np
import pytest

import coneshadow

SIZE = 64
# asm's node budget follows the clock (--asm-budget-ms); without one, every method's mask is the run's own.
SETTINGS = {"asm-budget-ms": 0}


def timeless(stats):
    """The stats that do not depend on the run's clock or the host's counters."""
    clocked = ("_ms", "ms_", "per_frame", "_per_frame", "gpu")
    return {k: v for k, v in stats.items() if not any(c in k for c in clocked)}


@pytest.fixture(scope="module")
def every_method(builtin, cli, tmp_path_factory):
    methods = coneshadow.methods()
    out = tmp_path_factory.mktemp("cli")
    subprocess.run([cli, "render", "--methods", ",".join(methods), "--width", str(SIZE), "--height", str(SIZE),
                    "--frames", "1", "--asm-budget-ms", "0", "--quiet", "--out", str(out / "out"), "--dump", str(out / "dump")],
                   check=True, stdout=subprocess.DEVNULL)
    rows = json.loads((out / "out" / "results.json").read_text())
    frame = coneshadow.render(builtin, methods=methods, width=SIZE, height=SIZE, frames=1, settings=SETTINGS)
    return frame, rows, out / "dump"


def test_every_method_has_the_cli_rows(every_method):
    frame, rows, _ = every_method
    assert [r["method"] for r in frame.rows] == [r["method"] for r in rows]
    for mine, theirs in zip(frame.rows, rows):
        name = theirs["method"]
        assert mine.keys() == theirs.keys(), name
        assert mine["error"] == theirs["error"], name
        assert mine["stats"].keys() == theirs["stats"].keys(), name
        assert timeless(mine["stats"]) == timeless(theirs["stats"]), name
        assert [s["name"] for s in mine["stages"]] == [s["name"] for s in theirs["stages"]], name
        assert mine["provenance"].keys() == theirs["provenance"].keys(), name
        for key in ("scene", "view", "width", "height", "device", "bytes"):
            assert mine[key] == theirs[key], (name, key)
        assert frame.results[name] == mine


def test_every_method_has_the_cli_masks_and_samples(every_method):
    from conftest import read_pfm
    frame, rows, dump = every_method
    for r in rows:
        name = r["method"]
        mask = read_pfm(dump / ("visibility_%s.pfm" % name))
        assert frame.visibility[name].shape == (SIZE, SIZE)
        assert frame.visibility[name].dtype == np.float32
        np.testing.assert_array_equal(frame.visibility[name], mask, err_msg=name)
    np.testing.assert_array_equal(frame.position, read_pfm(dump / "position.pfm"))
    np.testing.assert_array_equal(frame.band, read_pfm(dump / "band.pfm") > 0)
    np.testing.assert_array_equal(frame.reference, frame.visibility["embree"])
    assert frame.lit.sum() == rows[0]["stats"]["lit_samples"]
    assert frame.band.sum() == rows[0]["stats"]["band_samples"]


def test_several_lights_are_the_clis_frames(builtin, cli, tmp_path):
    lo, hi = map(np.array, builtin.bounds)
    lights = np.array([lo + (hi - lo) * [0.5, 0.8, 0.5], lo + (hi - lo) * [0.3, 0.7, 0.6]], np.float32)
    frame = coneshadow.render(builtin, lights=lights, methods=["cone"], width=32, height=32, frames=1)
    assert frame.visibility["cone"].shape == (2, 32, 32)
    assert frame.lit.shape == frame.band.shape == frame.reference.shape == (2, 32, 32)
    assert len(frame.results["cone"]) == 2 and len(frame.rows) == 4
    args = [cli, "render", "--methods", "cone", "--width", "32", "--height", "32", "--frames", "1", "--quiet",
            "--out", str(tmp_path)]
    for l in lights:
        args += ["--light", ",".join(repr(float(x)) for x in l)]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    rows = json.loads((tmp_path / "results.json").read_text())
    assert [(r["method"], r["stats"]["light_index"]) for r in frame.rows] == \
        [(r["method"], r["stats"]["light_index"]) for r in rows]
    for mine, theirs in zip(frame.rows, rows):
        assert mine["error"] == theirs["error"] and mine["stats"]["light"] == theirs["stats"]["light"]
    # Each light's frame is its one-light frame; 'all' is every light of the scene (the CLI's --all-lights).
    one = coneshadow.render(builtin, lights=lights[1], methods=["cone"], width=32, height=32, frames=1)
    np.testing.assert_array_equal(one.visibility["cone"], frame.visibility["cone"][1])
    assert one.results["cone"]["error"] == frame.results["cone"][1]["error"]
    every = coneshadow.render(builtin, lights="all", methods=["cone"], width=32, height=32, frames=1)
    assert every.visibility["cone"].shape == (len(builtin.lights), 32, 32)


def test_compare_returns_the_rows_it_writes(builtin, tmp_path):
    rows = coneshadow.compare(builtin, views=["fur"], methods=["cone", "cubesm"], width=32, height=32, frames=1,
                              out=tmp_path)
    written = json.loads((tmp_path / "results.json").read_text())
    assert [r["stats"]["setting"] for r in rows] == [r["stats"]["setting"] for r in written]
    assert [r["error"] for r in rows] == [r["error"] for r in written]
    assert {r["method"] for r in rows} == {"cone", "cubesm"}
    assert all(r["view"] == "fur" and r["stats"]["timing"] == "sequential" for r in rows)
    assert any(r["stats"]["setting"] != "cubesm" for r in rows if r["method"] == "cubesm")  # its sweep


def test_the_callers_floating_point_mode_survives(builtin):
    # The reference's threads flush denormals to zero; the calling thread's (numpy's) mode stays its own.
    coneshadow.render(builtin, methods=["cone"], width=16, height=16, frames=1)
    assert np.float64(1e-310) * np.float64(1.0) != 0.0
    assert np.float32(1e-40) * np.float32(1.0) != 0.0

# The pytest tests of `import coneshadow` (python/): ctest's test `python` (label python) runs them with
# PYTHONPATH=build/python and CONESHADOW_CLI naming the CLI; run by hand from the checkout with
#   PYTHONPATH=build/python python3 -m pytest -q python/tests
import os
import pathlib

import numpy as np
import pytest

import coneshadow

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("CONESHADOW_CLI") or str(ROOT / "build" / "app" / "coneshadow")
    if not os.access(path, os.X_OK):
        pytest.skip("no coneshadow CLI at " + path)
    return path


@pytest.fixture(scope="session")
def builtin():
    return coneshadow.Scene.builtin()


def read_pfm(path):
    """A PFM as the CLI's --dump writes it: rows bottom-first on disk, returned top-first (H, W[, 3])."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    image = data.reshape(height, width, channels)[::-1]
    return image[..., 0] if channels == 1 else image

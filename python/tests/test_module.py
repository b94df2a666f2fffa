# The package as the build lays it out: the extension, its stubs, the device and the registry.
import pathlib

import coneshadow


def test_the_package_holds_its_stubs():
    folder = pathlib.Path(coneshadow.__file__).parent
    assert (folder / "__init__.pyi").exists() and (folder / "py.typed").exists()
    assert list(folder.glob("_coneshadow*.so"))


def test_the_registry_and_the_device():
    assert coneshadow.methods()[:2] == ["embree", "cone"]
    assert coneshadow.device()  # the driver description, as the CLI's reports name it
    assert coneshadow.devices()
    assert "Vulkan device" in coneshadow.set_device.__doc__

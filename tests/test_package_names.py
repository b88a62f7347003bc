"""Every package says what it offers: a flat ``__all__`` whose names all import, cheaply."""

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = sorted(".".join(path.parent.relative_to(REPO).parts) for path in (REPO / "atlas_rap").rglob("__init__.py"))


@pytest.mark.parametrize("name", PACKAGES)
def test_each_package_lists_its_public_names_and_each_one_is_there(name):
    package = importlib.import_module(name)
    assert package.__all__, f"{name} has no __all__"
    missing = [public for public in package.__all__ if not hasattr(package, public)]
    assert missing == [], f"{name} lists names it does not have: {missing}"


def test_the_lazy_packages_import_a_name_from_its_module_and_refuse_others():
    from atlas_rap.maps import OccupancyGrid
    from atlas_rap.maps.grid import OccupancyGrid as from_module

    assert OccupancyGrid is from_module
    assert "OccupancyGrid" in dir(importlib.import_module("atlas_rap.maps"))
    with pytest.raises(AttributeError, match="has no attribute 'OccupancyGrd'"):
        importlib.import_module("atlas_rap.maps").OccupancyGrd


def test_importing_the_packages_imports_none_of_their_heavy_libraries():
    code = ("import sys, atlas_rap, atlas_rap.maps, atlas_rap.sim, atlas_rap.cli\n"
            "print(sorted(m for m in ('scipy', 'skimage', 'pymunk', 'numpy', 'click') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                          env={"PYTHONPATH": str(REPO)})
    assert done.stdout.strip() == "[]", done.stderr

"""The install lists every package and ships the MJCF models (a non-editable install would silently drop
an unlisted sub-package)."""
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_every_package_is_listed():
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())
    listed = set(cfg["tool"]["setuptools"]["packages"])
    found = set()
    for top, name in (("suspension_sim", "suspension_sim"), ("controllers", "suspension_sim.controllers")):
        for init in (REPO / top).rglob("__init__.py"):
            rel = init.parent.relative_to(REPO / top)
            if "__pycache__" not in rel.parts:
                found.add(".".join((name,) + rel.parts))
    missing = found - listed
    assert not missing, f"packages missing from pyproject.toml [tool.setuptools] packages: {sorted(missing)}"
    assert cfg["tool"]["setuptools"]["package-dir"]["suspension_sim.mjcf_models"] == "models"
    assert cfg["tool"]["setuptools"]["package-dir"]["suspension_sim.controllers"] == "controllers"


def test_controllers_install_inside_the_package():
    """The controllers are ``suspension_sim.controllers`` (no top-level ``controllers`` package listed)."""
    import suspension_sim.controllers.skyhook as sk
    from suspension_sim.registry import CONTROLLERS

    assert sk.__name__ == "suspension_sim.controllers.skyhook"
    assert CONTROLLERS.get("skyhook").__module__ == "suspension_sim.controllers.skyhook"
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "controllers" not in cfg["tool"]["setuptools"]["packages"]


def test_models_are_found():
    from suspension_sim.vehicles.base import models_dir

    names = {p.name for p in models_dir().glob("*.xml")}
    assert {"quarter_car.xml", "half_car.xml", "sdof.xml"} <= names

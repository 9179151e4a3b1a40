"""Name -> class registries for every pluggable piece (vehicles, effects, roads, actuators, controllers,
metrics, sensors, manoeuvres).

Adding a piece is one new file that registers itself::

    from suspension_sim.registry import EFFECTS

    @EFFECTS.register("quadratic_damping")
    class QuadraticDamping(Effect): ...

Modules are discovered by importing every module of the packages listed in ``_PACKAGES`` (and the
top-level ``controllers`` package), so nothing else needs to change.
"""
from __future__ import annotations

import importlib
import pkgutil
from typing import Callable, Generic, TypeVar

from .errors import ScenarioError

T = TypeVar("T")

_PACKAGES = [
    "suspension_sim.vehicles",
    "suspension_sim.effects",
    "suspension_sim.roads",
    "suspension_sim.actuators",
    "suspension_sim.metrics",
    "suspension_sim.sensors",
    "suspension_sim.controllers",
    # modules, not packages: the manoeuvres (full-car ones live in their own modules)
    "suspension_sim.maneuvers",
    "suspension_sim.maneuvers_dlc",
]
_loaded = False


def load_plugins() -> None:
    """Import every module of the plugin packages once, so that their ``register`` decorators run."""
    global _loaded
    if _loaded:
        return
    _loaded = True
    for pkg_name in _PACKAGES:
        pkg = importlib.import_module(pkg_name)
        if not hasattr(pkg, "__path__"):
            continue
        for info in pkgutil.iter_modules(pkg.__path__):
            if not info.name.startswith("_"):
                importlib.import_module(f"{pkg_name}.{info.name}")


class Registry(Generic[T]):
    def __init__(self, kind: str):
        self.kind = kind
        self._items: dict[str, T] = {}

    def register(self, name: str) -> Callable[[T], T]:
        def deco(obj: T) -> T:
            if name in self._items and self._items[name] is not obj:
                raise RuntimeError(f"{self.kind} '{name}' registered twice")
            self._items[name] = obj
            try:
                obj.name = name  # type: ignore[attr-defined]
            except (AttributeError, TypeError):
                pass
            return obj

        return deco

    def get(self, name: str, field: str | None = None, source: str | None = None) -> T:
        load_plugins()
        if name not in self._items:
            known = ", ".join(sorted(self._items))
            raise ScenarioError(f"unknown {self.kind} '{name}' (known: {known})", source=source, field=field)
        return self._items[name]

    def unregister(self, name: str) -> None:
        """Remove ``name`` (tests that register a piece for a while; unknown names are ignored)."""
        self._items.pop(name, None)

    def names(self) -> list[str]:
        load_plugins()
        return sorted(self._items)

    def items(self) -> list[tuple[str, T]]:
        load_plugins()
        return sorted(self._items.items())

    def __contains__(self, name: str) -> bool:
        load_plugins()
        return name in self._items


VEHICLES: Registry = Registry("vehicle model")
EFFECTS: Registry = Registry("effect")
ROADS: Registry = Registry("road")
ACTUATORS: Registry = Registry("actuator")
CONTROLLERS: Registry = Registry("controller")
METRICS: Registry = Registry("metric")
SENSORS: Registry = Registry("sensor")
MANEUVERS: Registry = Registry("manoeuvre")


def summary_line(obj) -> str:
    """First line of an object's docstring, for ``suspension-sim list``."""
    doc = (getattr(obj, "__doc__", None) or "").strip()
    return doc.splitlines()[0] if doc else ""

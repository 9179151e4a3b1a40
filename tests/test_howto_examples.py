"""The examples of ARCHITECTURE.md's "How to add ...": each new piece is one class (or function) registered by
name plus this kind of test.  Copy the part you need into a new file of the right package
(``controllers/``, ``suspension_sim/effects/``, ``roads/``, ``metrics/``, ``vehicles/``) and its test into
``tests/``; nothing else changes.

In your own file, register with the decorator (``@CONTROLLERS.register("my_controller")`` above the class).
Here the examples are registered by a fixture for the duration of this module only, so that they do not show
up in other tests (a registered metric is computed for every run).

Each example here is a plain-numpy component: it runs through the Python loop.  A built-in component writes
its law once as a numba kernel instead (see ``controllers/skyhook.py``, ``effects/quadratic_damping.py``),
which the compiled loop inlines and the base class broadcasts over the ensemble for the Python loop.
"""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.config import parse_scenario
from suspension_sim.controllers.base import Controller
from suspension_sim.effects.base import Effect
from suspension_sim.metrics.base import Accumulator, EnsembleView, RunView, metric
from suspension_sim.registry import CONTROLLERS, EFFECTS, METRICS, ROADS, VEHICLES
from suspension_sim.roads.base import Road
from suspension_sim.simulation import Simulation
from suspension_sim.vehicles.sdof import SDOF


# --- a controller: reads declared sensors, returns one command per corner --------------------------------
class GroundhookParams(Params):
    c_ground: float = Field(1500.0, ge=0, description="N·s/m")


class Groundhook(Controller):
    """F = c_ground · ż_wheel: damps the wheel's absolute motion (force + pushes the wheel down)."""

    Params = GroundhookParams

    @classmethod
    def required_sensors(cls, raw):
        return ["wheel_vel"]

    def step(self, t, y):
        return self.per_car(self.p.c_ground)[:, None] * y["wheel_vel"]


# --- an effect: a force along the suspension as a function of travel s and its rate v -------------------
class LinearSpringParams(Params):
    k: float = Field(5000.0, description="extra spring stiffness, N/m")


class ExtraSpring(Effect):
    """F = −k·s (stiffer suspension).  Signature: resonance moves up, static deflection unchanged."""

    Params = LinearSpringParams
    signature = "residual force proportional to travel"

    def force(self, s, v, t, dt):
        return -self.p.k * s


# --- a road: height under each wheel at corner time t and distance x ------------------------------------
class RampParams(Params):
    slope: float = Field(0.01, description="m of height per m of road")


class Ramp(Road):
    """z = slope · x (a steady climb)."""

    Params = RampParams

    def height(self, t, x, track=0):
        return self.p.slope * np.asarray(x, dtype=float)


# --- a metric: a function of one run's log -------------------------------------------------------------
def travel_range(run: RunView) -> dict:
    """Peak-to-peak suspension travel per corner (m)."""
    return {f"travel_range{s}": float(np.ptp(run.col(f"travel{s}"))) for s in run.suffixes}


# --- the same metric for speed: its law once, as an accumulator over chunks of (n_cars, samples) ---------
# (what the built-in metrics do): @metric makes of it the per-car function, the version for a whole ensemble
# at once (a batch) and the chunk-by-chunk version for long runs
@metric
class TravelSpan(Accumulator):
    """Peak-to-peak suspension travel per corner (m), every car at once."""

    channels = ("travel{s}",)  # what it reads ({s}: every corner), so that a batch logs it

    def update(self, chunk):
        for s in chunk.suffixes:
            x = chunk.col(f"travel{s}")  # (n_cars, rows)
            self.r.max(f"hi{s}", x)
            self.r.max(f"lo{s}", -x)

    def result(self):
        return {f"travel_span{s}": self.r.get(f"hi{s}") + self.r.get(f"lo{s}") for s in self.meta.suffixes}


# --- a vehicle: an MJCF file in models/ plus a class mapping scenario parameters onto it -----------------
class HeavyRig(SDOF):
    """The SDOF rig's file (models/sdof.xml) with a heavier default mass; a new vehicle names its own xml."""

    xml = "sdof.xml"

    class Params(SDOF.Params):
        sprung_mass: float = Field(400.0, gt=0, description="kg")


EXAMPLES = [(CONTROLLERS, "howto_groundhook", Groundhook), (EFFECTS, "howto_extra_spring", ExtraSpring),
            (ROADS, "howto_ramp", Ramp), (METRICS, "howto_travel_range", travel_range),
            (METRICS, "howto_travel_span", TravelSpan), (VEHICLES, "howto_heavy_rig", HeavyRig)]


@pytest.fixture(autouse=True, scope="module")
def registered():
    for reg, name, obj in EXAMPLES:  # what the decorator does in a component's own file
        reg.register(name)(obj)
    yield
    for reg, name, _ in EXAMPLES:
        reg.unregister(name)


def run(raw):
    sc = parse_scenario(raw)
    return Simulation([sc]).run()[0]


BASE = {"vehicle": {"model": "quarter_car"}, "road": {"type": "sine", "params": {"amplitude": 0.01, "frequency": 12}},
        "sensors": [{"name": "wheel_vel", "type": "wheel_vel"}], "actuator": {"type": "ideal"},
        "controller": {"type": "passive"}, "sim": {"duration": 2.0, "dt": 0.0005, "control_dt": 0.001}}


def with_(**over):
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in BASE.items()}
    raw.update(over)
    return raw


def test_controller_example_damps_the_wheel_and_passive_does_not():
    passive = run(with_())
    ground = run(with_(controller={"type": "howto_groundhook", "params": {"c_ground": 1500}}))
    a0, a1 = passive.metrics["wheel_acc_rms"], ground.metrics["wheel_acc_rms"]
    assert a1 < 0.9 * a0  # near the wheel resonance the groundhook cuts wheel acceleration; passive cannot


def test_effect_example_stiffens_the_suspension():
    base = with_(road={"type": "sine", "params": {"amplitude": 0.01, "frequency": 1.0}})
    soft = run(base)
    stiff = run({**base, "vehicle": {"model": "quarter_car", "effects": [{"type": "howto_extra_spring",
                                                                           "params": {"k": 30000}}]}})
    assert stiff.metrics["travel_rms"] < 0.8 * soft.metrics["travel_rms"]


def test_road_example_lifts_the_car():
    r = run(with_(road={"type": "howto_ramp", "params": {"slope": 0.01}, "speed": 10}))
    z = r.ts["body_z"].to_numpy()
    assert z[-1] > 0.15  # 2 s at 10 m/s up a 1 % slope: 0.2 m, the body follows
    assert abs(z[0]) < 1e-3


def test_metric_example_is_in_the_summary():
    r = run(with_())
    travel = r.ts["travel"].to_numpy()
    assert r.metrics["travel_range"] == np.ptp(travel)


def test_accumulator_metric_example_is_in_the_summary_and_streams():
    r = run(with_())
    travel = r.ts["travel"].to_numpy()
    assert r.metrics["travel_span"] == np.ptp(travel) > 0
    # a long run feeds it chunk by chunk: the same value
    t = r.ts["t"].to_numpy()
    acc = TravelSpan.stream(EnsembleView(channels={}, t=t[:0], suffixes=[""], static_tire_force={}, infos=[{}]))
    for a in range(0, len(t), 333):
        acc.update(EnsembleView(channels={"travel": travel[None, a:a + 333]}, t=t[a:a + 333], suffixes=[""],
                                static_tire_force={}, infos=[{}]))
    assert acc.result()["travel_span"][0] == np.ptp(travel)


def test_vehicle_example_is_heavier():
    raw = with_(vehicle={"model": "howto_heavy_rig"}, sensors=[], road={"type": "sine",
                "params": {"amplitude": 0.01, "frequency": 0.5}})
    heavy = run(raw)
    light = run({**raw, "vehicle": {"model": "sdof"}})
    # a heavier mass on the same spring: lower natural frequency, so at 0.5 Hz more travel
    assert heavy.metrics["travel_rms"] > light.metrics["travel_rms"]

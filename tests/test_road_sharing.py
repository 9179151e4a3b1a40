"""Cars of an ensemble with the same road, seed, speed and wheelbase share one road object (built once), and
each distinct wheel path is evaluated once per chunk; the heights are those of cars built alone."""
from __future__ import annotations

import numpy as np

from suspension_sim.config import parse_scenario
from suspension_sim.simulation import Simulation


def _sc(seed, mass=290.0):
    return parse_scenario({"name": "s", "vehicle": {"model": "quarter_car", "params": {"sprung_mass": mass}},
                           "road": {"type": "iso8608", "params": {"road_class": "C"}, "speed": 20.0, "seed": seed},
                           "sim": {"duration": 0.5, "dt": 5e-4}})


def test_equal_roads_are_shared_and_give_the_heights_of_cars_built_alone():
    sim = Simulation([_sc(1), _sc(1, mass=350.0), _sc(2)])
    assert sim.roads[0] is sim.roads[1]  # same road: built once
    assert sim.roads[2] is not sim.roads[0]  # another seed: its own road
    z, zd = sim.road_chunk(0, 800)[:2]
    for i, sc in enumerate([_sc(1), _sc(1, mass=350.0), _sc(2)]):
        z1, zd1 = Simulation([sc]).road_chunk(0, 800)[:2]
        assert np.array_equal(z[i], z1[0]) and np.array_equal(zd[i], zd1[0])
    assert not np.array_equal(z[0], z[2])

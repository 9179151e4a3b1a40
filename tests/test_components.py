"""Stacking of per-car component parameters into ensemble arrays."""
import numpy as np


def test_stack_params_mixes_scalars_and_corner_lists():
    from suspension_sim.components import stack_params
    from suspension_sim.effects.bump_stop import BumpStop

    a = BumpStop.Params(gap=0.05, stiffness=4e4)
    b = BumpStop.Params(gap=[0.05, 0.07], stiffness=5e4)
    st = stack_params([a, b], 2)
    np.testing.assert_array_equal(st.gap, [[0.05, 0.05], [0.05, 0.07]])
    np.testing.assert_array_equal(st.stiffness, [[4e4], [5e4]])


def test_validate_many_validates_each_distinct_mapping_once_and_tells_types_apart(monkeypatch):
    import pytest

    from suspension_sim import components
    from suspension_sim.effects.bump_stop import BumpStop
    from suspension_sim.errors import ScenarioError

    calls = []
    orig = components.validate_params

    def counting(model, raw, field, source=None):
        calls.append(raw)
        return orig(model, raw, field, source)

    monkeypatch.setattr(components, "validate_params", counting)
    same = [{"gap": 0.05, "stiffness": 4e4} for _ in range(50)]
    out = components.validate_many(BumpStop.Params, same, "vehicle.effects.0.params")
    assert len(calls) == 1 and len(out) == 50 and all(p is out[0] for p in out)
    assert out[0] == orig(BumpStop.Params, same[0], "f")
    # values a validation can tell apart are validated apart: int and float, the sign of zero, a list's entries
    calls.clear()
    raws = [{"gap": 0.05, "damping": 0.0}, {"gap": 0.05, "damping": -0.0},
            {"gap": [0.05, 0.07]}, {"gap": [0.05, 0.08]}, {"stiffness": 40000}, {"stiffness": 40000.0}, None, {}]
    out = components.validate_many(BumpStop.Params, raws, "p")
    assert len(calls) == len(raws)
    assert [p == orig(BumpStop.Params, r, "p") for p, r in zip(out, raws)] == [True] * len(raws)
    # a bad mapping gives validate_params's own one-line error, shared or not
    with pytest.raises(ScenarioError) as a:
        components.validate_many(BumpStop.Params, [{"gap": 0.05}, {"gap": True}, {"gap": True}], "p", "s.yaml")
    with pytest.raises(ScenarioError) as b:
        orig(BumpStop.Params, {"gap": True}, "p", "s.yaml")
    assert str(a.value) == str(b.value)

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

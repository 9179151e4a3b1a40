"""The car at rest when its weight changed after it was levelled (a load added, the ride height not reset).

A scenario's springs carry the static loads at zero travel (the car is levelled: :mod:`.vehicles.base`).
When the masses differ from the ones it was levelled with (``vehicle.levelled_with`` of a scenario, or a
fitted mass in the discrepancy search), the car rests elsewhere: where its springs and its suspension
effects carry the changed weight.  :func:`rest_offset` finds that place, measured from the levelled ride
height (so a stop's gap and a cubic spring's zero stay where they are on the car).  Both ``suspension-sim
run`` (:class:`~suspension_sim.build.System`) and the search's engine (:mod:`.diagnose.engine`) start a run
there, with this one function.
"""
from __future__ import annotations

import mujoco
import numpy as np


def tendon_jacobian(m) -> np.ndarray:
    """(ntendon, nv) coefficients of the fixed tendons."""
    J = np.zeros((m.ntendon, m.nv))
    for i in range(m.ntendon):
        for j in range(m.tendon_adr[i], m.tendon_adr[i] + m.tendon_num[i]):
            if m.wrap_type[j] == mujoco.mjtWrap.mjWRAP_JOINT:
                J[i, m.jnt_dofadr[m.wrap_objid[j]]] += m.wrap_prm[j]
    return J


def gravity(m, d) -> np.ndarray:
    """Generalized gravity force at q = 0, v = 0 (``d`` is scratch data: it is reset)."""
    mujoco.mj_resetData(m, d)
    mujoco.mj_forward(m, d)
    return -d.qfrc_bias.copy()


def rest_offset(plant, effects, dg: np.ndarray, J: np.ndarray) -> np.ndarray:
    """The generalized positions (nv; zero on the road dofs) at which the car rests when ``dg`` (nv) is the
    generalized force that the levelled springs do not carry at q = 0 (the changed weight):
    −K·q + Δg + J_sᵀ·F(J_s·q) = 0 over the free dofs, F the suspension effects' forces at rest (Newton, their
    slopes by finite differences).  Only effects whose force at rest is a function of the travel alone count
    (:attr:`~suspension_sim.effects.base.Effect.static_law`: not hysteresis or backlash); stateless laws are zero
    at zero travel, so with no effect (or sizes at zero) this is the linear sag K⁻¹·Δg.  ``effects``: the
    simulation's [(effect, corner selection)]; each is reset after use."""
    P, m = plant, plant.model
    free = P.free_v
    dg = np.asarray(dg, float)[free]
    K = ((J.T * m.tendon_stiffness) @ J)[np.ix_(free, free)]
    Js = J[P.susp_t.reshape(-1)][:, free]  # (n·nc, nfree): travel rows, car-major
    eff = [(e, sel) for e, sel in effects if getattr(e, "target", "suspension") == "suspension"
           and getattr(e, "static_law", True)]
    n, nc = P.n, P.nc

    def force(q):
        s = (Js @ q).reshape(n, nc)
        F = np.zeros((n, nc))
        for e, sel in eff:
            F[:, sel] += np.asarray(e.force(s[:, sel], np.zeros_like(s[:, sel]), 0.0, P.dt), float)
            e.reset()
        return F.reshape(-1)

    q = q_lin = np.linalg.solve(K, dg)
    if eff:
        h = 1e-7
        for _ in range(60):
            F = force(q)
            G = -K @ q + dg + Js.T @ F
            dF = (force(q + np.linalg.lstsq(Js, np.full(Js.shape[0], h), rcond=None)[0]) - F) / h
            H = -K + (Js.T * dF) @ Js
            step = np.linalg.solve(H, -G)
            q = q + step
            if not np.all(np.isfinite(q)):
                break
            if np.max(np.abs(step)) < 1e-12:
                break
        if not np.all(np.isfinite(q)):
            q = q_lin
    q0 = np.zeros(m.nv)
    q0[free] = q
    return q0

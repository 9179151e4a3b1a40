"""Compiled closed loop: the per-step work of :class:`~suspension_sim.simulation.Simulation` in one numba loop.

The Python loop (``loop.py``) calls component methods every 0.5 ms physics step; the Python round
trip, not the arithmetic, then dominates (≈ 50 µs per step for a lone quarter car against 2 µs of MuJoCo).
A built-in component's law is a *kernel* (a numba function for one corner or one car), which the Python
loop runs broadcast over the ensemble (:mod:`suspension_sim.kernels`).  When every component of a scenario
has one, :mod:`suspension_sim.compiled.loop` generates a loop for that combination that calls MuJoCo's
``mj_step1``/``mj_step2`` itself, with the components' kernels inlined, and runs whole road chunks per call:
the same functions on the same numbers, so the results are those of the Python loop (tests compare the two
loops).  A component without a kernel (plain numpy methods) keeps working: the Python loop runs instead
(effects, actuators), or the compiled loop returns to Python at each control instant (controllers, sensors
without a kernel).

Kernel protocol (all optional; arrays float64 and C-contiguous; ``p`` rows are read-only parameters,
``st`` rows are state the kernel updates in place):

Effects (``suspension_sim.effects.base.Effect``)
    ``kernel(s, v, t, dt, p, st) -> float``: the force of one corner of one car (``force`` broadcasts it).
    ``kernel_data() -> (p, st)``: shapes ``(n_cars, n_sel, kp)`` and ``(n_cars, n_sel, ks)`` (``ks`` may be
    0) from the effect's current (reset) state.
    ``kernel_signals() -> {signal name: j}``: ``signals()[name][:, c] == st[:, c, j]``.

Actuators (``suspension_sim.actuators.base.Actuator``)
    ``kernel_force(cmd, s, v, t, dt, p, st) -> float`` and ``kernel_advance(cmd, s, v, t, dt, p, st)``:
    the force of one corner, and its state advanced over ``dt`` (``force`` and ``advance`` broadcast them).  ``kernel_data() -> (p, st)``: ``(n_cars, n_corners, kp)``,
    ``(n_cars, n_corners, ks)``.  ``kernel_states() -> {state name: j}``: ``states()[name][:, c] ==
    st[:, c, j]`` (``"force"`` may be left out: the loop keeps the force it returns).

Controllers (``controllers.base.Controller``)
    ``kernel(t, y, p, st, u)``: ``step`` for one car.  ``y``: this car's readings, the declared sensors
    concatenated in declared order (``ControlContext.sensor_slice(name)`` gives a sensor's slice); ``u``:
    the output row (n_corners), to be filled.  ``kernel_data() -> (p, st)``: ``(n_cars, kp)``,
    ``(n_cars, ks)``; ``p`` usually holds the sensor offsets it needs.  ``kernel_signals() -> {signal name:
    (start, stop)}``: ``signals()[name] == st[:, start:stop]`` (width 1: a 1-D signal).
    ``kernel_sync(st)`` (optional): write the final kernel state back to the Python attributes.

Sensors (``suspension_sim.sensors.base.Sensor``)
    ``kernel_field() -> (PlantState field name, column indices) | None``: the sensor reads those columns of
    one plant quantity (all built-in field sensors); the measurement pipeline is compiled in the loop.
"""

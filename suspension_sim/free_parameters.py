"""Free-parameter declarations: how ``suspension-sim diagnose`` may fit a component's parameters.

An effect (or actuator) that carries a class attribute ``free_parameters = {param: FreeParameter(...)}`` is a
candidate of the discrepancy workflow with no edit in :mod:`suspension_sim.diagnose`: the workflow adds it
to the model, fits the declared parameters (with everything already free) and names it when it explains
the data.  ``fit_settings`` (optional dict) fixes the effect's other settings for the fit (e.g. the friction
law).  The signature the effect leaves in data is its ``signature`` attribute.

A declaration is in units of a *data scale*, an expression of the magnitudes the workflow measures on the
nominal model's simulation of the record: ``s`` (RMS travel, m), ``s_max`` (largest |travel|), ``s_comp`` and
``s_ext`` (largest compression and extension), ``v`` (RMS travel rate, m/s), ``F`` (RMS linear suspension
force, N), ``k`` (spring stiffness, N/m), ``c`` (damping, N·s/m); ``"1"`` means SI units.  Example (bump
stops): each side's gap starts at 0.7 of the largest travel to that side, the stiffness at 2·max(k, F/s)::

    free_parameters = {"gap_compression": FreeParameter("s_comp", init=0.7, lo=1e-6, hi=2.0, size=False),
                       "gap_extension": FreeParameter("s_ext", init=0.7, lo=1e-6, hi=2.0, size=False),
                       "stiffness": FreeParameter("max(k, F/s)", init=2.0)}

An effect that *generalises* a linear element of the car declares it (``contains = {quantity: (pos, neg)}``,
quantity ``damping`` or ``stiffness``, two of its parameters): with both equal to the car's linear suspension
``quantity`` of its corners (and that set to 0), the effect is that element.  Asymmetric damping contains the
linear damping (``{"damping": ("c_reb", "c_comp")}``: c_comp = c_reb = c is a linear damper c).  Beside a free
linear damping of the same corners the three would parametrise two totals (adding δ to the damping and taking
it from both rates changes nothing: the fit is singular along that line, and the search read the damping
"driven to zero" by a stand-in).  The workflow then fits the pair as one signed difference ``pos_minus_neg``
= pos − neg (pos = max(d, 0), neg = max(−d, 0)): the linear parameter carries what the two sides share, the
effect the excess of one side, and its size is that difference.  (Fitting the totals in the effect with the
linear damping held at 0 was tried: the effect's force is explicit in the physics step while MuJoCo's
linear damper is implicit, and the model then missed the noise-free blind records by about twice as much.)

An effect may also say what fitted values mean on the record (``fitted_notes(params, travel, ci95) ->
{param: text}``, static; e.g. a bump stop's gap beyond the largest travel, or not distinguishable from one:
"no extension stop"); the report gives the notes beside the values and in the verdict.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FreeParameter:
    """One fitted parameter.  ``init``, ``lo``, ``hi`` and ``starts`` are multiples of ``scale`` (an
    expression of the data scales); ``lo``/``hi`` None = unbounded.  ``starts``: alternative starting values
    (multi-start; the k-th start of every parameter that has them is used together).  ``size``: the
    parameter measures how strong the effect is (an effect whose sizes are indistinguishable from zero is
    pruned).  ``candidate``: the candidate's name when it is not the component's (actuators: one candidate
    per parameter); ``target``: where the value goes when it is not the component's parameter of that name
    (``input.delay``: the measured force input is shifted in time).  ``unseen`` (a multiple of ``scale``, at
    most ``hi``): the value the fit leaves the parameter at when the fitted window does not determine it at all
    (its Jacobian column is exactly zero: a stop the record never reaches), for a parameter whose effect only
    weakens as it moves there (a gap), so that the model does not predict unseen data with an effect placed
    wherever its start happened to be."""

    scale: str = "1"
    init: float = 0.0
    lo: float | None = 0.0
    hi: float | None = None
    starts: tuple = ()
    size: bool = True
    candidate: str | None = None
    target: str | None = None
    unseen: float | None = None  # where the parameter goes when the fitted window does not determine it

    def value(self, x: float, scales: dict) -> float:
        return float(x) * scale_of(self.scale, scales)


def scale_of(expr: str, scales: dict) -> float:
    """The value of a scale expression (``"F/v**2"``) for the data scales given."""
    v = eval(expr, {"__builtins__": {}, "max": max, "min": min, "abs": abs}, dict(scales))  # noqa: S307
    v = float(v)
    if not v == v or v in (float("inf"), float("-inf")) or v == 0.0:
        return 1e-12 if v == 0.0 else 1.0
    return abs(v)

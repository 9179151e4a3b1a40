"""RMS and peak actuator force per corner."""
from ..registry import METRICS
from ._util import peak
from .base import RunView, rms


@METRICS.register("actuator_force")
def actuator_force(run: RunView) -> dict:
    """RMS and peak (max |F|) delivered actuator force per corner (N); zero for a passive run."""
    out = {}
    for s in run.suffixes:
        f = run.ts[f"actuator_force{s}"].to_numpy()
        out[f"actuator_force_rms{s}"] = rms(f)
        out[f"actuator_force_peak{s}"] = peak(f)
    return out

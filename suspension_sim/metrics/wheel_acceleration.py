"""RMS and peak wheel (unsprung mass) acceleration per corner."""
from ..registry import METRICS
from ._util import peak
from .base import RunView, rms


@METRICS.register("wheel_acc")
def wheel_acc(run: RunView) -> dict:
    """RMS and peak vertical wheel acceleration per corner (m/s²)."""
    out = {}
    for s in run.suffixes:
        a = run.ts[f"wheel_acc{s}"].to_numpy()
        out[f"wheel_acc_rms{s}"] = rms(a)
        out[f"wheel_acc_peak{s}"] = peak(a)
    return out

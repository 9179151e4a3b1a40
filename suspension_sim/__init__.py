"""suspension_sim: an active-suspension testbed on MuJoCo.

Data flows one way: scenario file -> validated config (:mod:`.config`) -> build (:mod:`.build`: the
MuJoCo model of :mod:`.plant`, road, effects, actuator, sensors, controller) -> loop (:mod:`.loop`,
:mod:`.compiled.loop`) -> log (:mod:`.log`) -> metrics and results (:mod:`.metrics`, :mod:`.results`) ->
outputs (:mod:`.outputs`, plots, report, :mod:`.viewer`); :mod:`.simulation` puts build, loop and log
together.  ``tests/test_architecture.py`` checks that imports follow these layers.
"""
import os as _os

# dm_control imports a rendering backend on import; the simulator renders nothing itself.
_os.environ.setdefault("MUJOCO_GL", "egl")
# The models are tiny, so BLAS threads never help; OpenBLAS's idle threads spin after each call and doubled
# the CPU time of a run (and stole the cores of parallel batch workers).  One BLAS thread, unless the user
# says otherwise; Simulation.run also limits BLAS to one thread while it runs (numpy may be loaded first).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

# numba's on-disk cache: saves of new signatures locked between processes (batch workers, pytest-xdist)
from .numba_cache import install as _lock_numba_cache  # noqa: E402

_lock_numba_cache()

from .version import __version__  # noqa: E402
from .config import Scenario, load_scenario  # noqa: E402
from .errors import ScenarioError, SimulationDiverged  # noqa: E402


def simulate(scenario, **kwargs):
    """Simulate a scenario (a :class:`Scenario`, a path, or a list of structurally equal scenarios run as
    one ensemble). Returns a :class:`~suspension_sim.results.Result` (or a list for a list)."""
    from .simulation import simulate as _simulate

    return _simulate(scenario, **kwargs)


def _register_gym_envs():
    """``gymnasium.make("suspension_sim/QuarterCar-v0")`` etc. work after ``import suspension_sim``."""
    try:
        from .rl import register_envs

        register_envs()
    except ImportError:  # pragma: no cover - gymnasium missing
        pass


_register_gym_envs()

__all__ = ["Scenario", "load_scenario", "simulate", "ScenarioError", "SimulationDiverged", "__version__"]

import functools
import os
import re
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

REPO = Path(__file__).resolve().parents[1]
REAL_DATA = (REPO.parent / "shared" / "data" / "real")


@pytest.fixture
def repo() -> Path:
    return REPO


@pytest.fixture
def real_data() -> Path:
    if not REAL_DATA.exists():
        pytest.skip(f"real measured data not found at {REAL_DATA}")
    return REAL_DATA


# -- pytest -n N: keep a module's tests on one worker when they share a module-scoped fixture --------------
# xdist's default (--dist load) hands each worker chunks of consecutive tests; a chunk may end inside a module,
# and then both workers build that module's module-scoped fixtures (often a whole simulation study, with its
# compiled loop).  The chunks end in the middle of such a module no more: a chunk that would is carried on to
# the module's end (xdist's --dist loadgroup would do it with marks, but with pytest 9 it no longer groups:
# it renames item._nodeid, which pytest 9 does not read).  The test function that runs every scenario file
# (tests/test_compiled_loop.py) is kept together per family of files (kim_fig2..5 compile one loop).
_SHARED_FIXTURE = re.compile(r"""@pytest\.fixture\([^)]*scope\s*=\s*["'](?:module|class|package|session)["']""")
_TOGETHER = {"tests/test_compiled_loop.py::test_scenario_files_agree":
             lambda param: "_".join(param.split("_")[:2] if param.split("_")[0] in ("thesis", "full") else param.split("_")[:1])}


@functools.lru_cache(maxsize=None)
def _shares_fixtures(module: str) -> bool:
    try:
        return bool(_SHARED_FIXTURE.search((REPO / module).read_text(encoding="utf-8")))
    except OSError:
        return False


def xdist_group_of(nodeid: str) -> str | None:
    """The tests with one group name run on one worker (None: the test goes where xdist sends it)."""
    module = nodeid.split("::")[0]
    if _shares_fixtures(module):
        return module
    func, _, param = nodeid.partition("[")
    if func in _TOGETHER:
        return f"{func}[{_TOGETHER[func](param.rstrip(']'))}]"
    return None


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist (installed with .[test])
def pytest_xdist_make_scheduler(config, log):
    if config.getvalue("dist") != "load":
        return None  # another --dist mode asked for: xdist's own
    from xdist.scheduler import LoadScheduling

    class GroupedLoadScheduling(LoadScheduling):
        def _send_tests(self, node, num):
            if self.collection is not None and 0 < num < len(self.pending):
                group = xdist_group_of(self.collection[self.pending[num - 1]])
                while group is not None and num < len(self.pending) \
                        and xdist_group_of(self.collection[self.pending[num]]) == group:
                    num += 1
            super()._send_tests(node, num)

    return GroupedLoadScheduling(config, log)

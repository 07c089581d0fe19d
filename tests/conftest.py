"""Shared pytest fixtures: lazily built test FMUs.

``test_fmus`` is a session-scoped, read-only mapping from keys to FMU paths;
an FMU is built (see ``tests/fmu_factory.py``) the first time its key is
looked up and cached for the rest of the session:

    c2:MassA  c2:MassB  c2:Integrator  c2:Gain  c2:Faulty   FMI 2.0 CS (C)
    c3:Integrator                                          FMI 3.0 CS (C)
    me2:Oscillator                                         FMI 2.0 ME (C)
    py:MassA  py:MassB  py:Integrator  py:Gain  py:Faulty  py:Types
                                                           FMI 2.0 CS (pythonfmu)

``test_fmus.keys()`` lists every available key.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path

import pytest

TESTS_DIR = Path(__file__).resolve().parent
if str(TESTS_DIR) not in sys.path:
    # make analytic, fmu_factory, ssp_helpers and peers importable from
    # test modules in sub-directories as well
    sys.path.insert(0, str(TESTS_DIR))

import fmu_factory  # noqa: E402


def _keep_fmu_libraries_loaded():
    """fmpy unloads an FMU's shared library (dlclose) after simulate_fmu and freeInstance. A pythonfmu binary
    does not survive that inside a running interpreter: its finalizer touches interpreter state, and the
    process later crashes in unrelated code (seen as segfaults during garbage collection). cosim-master
    itself never unloads FMU libraries; the tests that call fmpy directly keep them loaded too."""
    import fmpy.fmi1
    fmpy.fmi1._FMU.freeLibrary = lambda self: None


_keep_fmu_libraries_loaded()


# pythonfmu 0.7 binaries keep a static PyState (with a worker thread) that C++ destroys at process exit,
# after the interpreter has finalized; when the tests have loaded such binaries in this process (fmpy's
# simulate_fmu, --no-inprocess runs) the exit then aborts now and then ("corrupted double-linked list",
# exit status 134: seen in about 1 of 10 runs of the four test modules that do it, never in a test).
# The session's own exit status is what counts, so the main process leaves without running exit-time
# destructors once pytest has reported everything (COSIM_TEST_NORMAL_EXIT=1: exit normally, to study it).
# (xdist workers report before they exit; they are left alone.)
def pytest_sessionfinish(session, exitstatus):
    session.config._cosim_exitstatus = int(exitstatus)
    if "program_server" in sys.modules:         # its servers waited for: their children's CPU is counted with ours
        sys.modules["program_server"].stop_servers()


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    status = getattr(config, "_cosim_exitstatus", None)
    if status is None or hasattr(config, "workerinput") or os.environ.get("COSIM_TEST_NORMAL_EXIT"):
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


class LazyFMUs(Mapping):
    """Mapping key -> FMU path that builds on first access."""

    def __init__(self, root: Path):
        self.root = Path(root)
        self._cache: dict[str, Path] = {}

    def __getitem__(self, key: str) -> Path:
        if key not in self._cache:
            if key not in fmu_factory.available_keys():
                raise KeyError(f"unknown test FMU {key!r}; available: {fmu_factory.available_keys()}")
            self._cache[key] = fmu_factory.build_by_key(key, self.root)
        return self._cache[key]

    def __iter__(self):
        return iter(fmu_factory.available_keys())

    def __len__(self) -> int:
        return len(fmu_factory.available_keys())

    def __contains__(self, key) -> bool:
        return key in fmu_factory.available_keys()

    def __repr__(self) -> str:
        return f"LazyFMUs(root={self.root}, built={sorted(self._cache)})"


@pytest.fixture(scope="session")
def test_fmus(tmp_path_factory) -> LazyFMUs:
    return LazyFMUs(tmp_path_factory.mktemp("test_fmus"))


def _shared_dir() -> Path:
    """``shared/`` beside the clone (developers' machines and CI), where the reference FMUs and SITL live."""
    return TESTS_DIR.parent.parent / "shared"


@pytest.fixture(scope="session")
def reference_fmus() -> Path:
    """The Modelica Reference FMUs (``shared/reference-fmus``: fmi2/, fmi3/, ref/); skips when absent."""
    root = _shared_dir() / "reference-fmus"
    if not (root / "fmi2").is_dir():
        pytest.skip(f"the Modelica Reference FMUs are not in {root}")
    return root

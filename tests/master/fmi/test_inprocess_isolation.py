"""In process, every pythonfmu FMU runs the code it bundles, even when a module of the same name is already
imported (the installed package, another FMU's copy); FMUs with identical bundles share one module.

The probe FMU outputs y = GAIN * t + VALUE after each step, where GAIN comes from its package's ``core`` module
(imported at module level) and VALUE from its ``late`` module, imported inside do_step (a function-level import,
which resolves at run time). Its ``serial`` output numbers the instances made from one module object.
"""
import subprocess
import sys
from pathlib import Path

import numpy as np

import master
from master.fmi.cache import load_fmu
from master.fmi.inprocess import load_slave_module

from ssp_helpers import write_ssp  # noqa: E402

SLAVE = '''
import itertools

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real

import {pkg}.core

_serials = itertools.count()


class {model}(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.serial = next(_serials)
        self.register_variable(Real("y", causality=Fmi2Causality.output))
        self.register_variable(Integer("serial", causality=Fmi2Causality.output,
                                       variability=Fmi2Variability.discrete))

    def do_step(self, current_time, step_size):
        import {pkg}.late
        self.y = {pkg}.core.GAIN * (current_time + step_size) + {pkg}.late.VALUE + {pkg}.core.relative()
        return True
'''
# core.relative() does a relative import inside a function: 0 from the bundled late module (as a check that it
# resolves in the FMU's package too)
CORE = "GAIN = {gain}\n\n\ndef relative():\n    from .late import OFFSET\n    return OFFSET\n"
LATE = "VALUE = {value}\nOFFSET = {offset}\n"


def _package(root: Path, pkg: str, gain: float, value: float, offset: float = 0.0) -> Path:
    (root / pkg).mkdir(parents=True)
    (root / pkg / "__init__.py").write_text("")
    (root / pkg / "core.py").write_text(CORE.format(gain=gain))
    (root / pkg / "late.py").write_text(LATE.format(value=value, offset=offset))
    return root


def _fmu(tmp: Path, label: str, model: str, pkg: str, gain: float, value: float, note: str = "") -> Path:
    src = _package(tmp / label, pkg, gain, value)
    (src / f"{model}.py").write_text(SLAVE.format(model=model, pkg=pkg))
    extra = []
    if note:            # a non-Python resource: a different archive with the same Python code
        (src / "note.txt").write_text(note)
        extra = ["note.txt"]
    exe = Path(sys.executable).with_name("pythonfmu")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "pythonfmu"]
    subprocess.run(cmd + ["build", "-f", f"{model}.py", pkg, *extra, "-d", "out"], cwd=src, check=True,
                   capture_output=True)
    return src / "out" / f"{model}.fmu"


def _run(tmp: Path, label: str, components: dict):
    ssp = write_ssp(tmp / f"{label}.ssp", components, stop=1.0, step=0.25)
    return master.run(ssp, output=tmp / f"run_{label}", inprocess=True, stop_time=1.0, step=0.25, record=["*"])


def _expect_y(frame, comp, gain, value):
    t = frame["time"].to_numpy()
    y = frame[f"{comp}.y"].to_numpy()
    assert np.array_equal(y[1:], gain * t[1:] + value), (comp, y)


def test_two_fmus_with_one_module_name_each_run_their_own_code(tmp_path):
    a = _fmu(tmp_path, "a", "IsoTwin", "iso_twin_pkg", gain=2.0, value=10.0)
    b = _fmu(tmp_path, "b", "IsoTwin", "iso_twin_pkg", gain=3.0, value=20.0)
    res = _run(tmp_path, "twins", {"a": a, "b": b})
    _expect_y(res.frame, "a", 2.0, 10.0)
    _expect_y(res.frame, "b", 3.0, 20.0)
    log = (tmp_path / "run_twins" / "fmu.log").read_text()
    assert "b: loaded in isolation: iso_twin_pkg differs from the imported copy" in log
    assert "a: loaded in isolation" not in log          # the first one is imported as usual


def test_bundled_package_wins_over_an_imported_one_also_in_function_level_imports(tmp_path, monkeypatch):
    pkg = "iso_global_pkg"
    _package(tmp_path / "installed", pkg, gain=5.0, value=50.0, offset=7.0)
    monkeypatch.syspath_prepend(str(tmp_path / "installed"))
    import iso_global_pkg.core
    import iso_global_pkg.late      # noqa: F401  (the global copy of the module the FMU imports in do_step)
    fmu = _fmu(tmp_path, "fmu", "IsoGlobal", pkg, gain=2.0, value=10.0)
    res = _run(tmp_path, "global", {"p": fmu})
    _expect_y(res.frame, "p", 2.0, 10.0)                # not 5 t + 50 + 7 (the imported copy)
    assert iso_global_pkg.core.GAIN == 5.0 and iso_global_pkg.core.relative() == 7.0


def test_identical_bundles_share_one_module(tmp_path):
    one = _fmu(tmp_path, "one", "IsoSame", "iso_same_pkg", gain=2.0, value=1.0, note="first archive")
    two = _fmu(tmp_path, "two", "IsoSame", "iso_same_pkg", gain=2.0, value=1.0, note="second archive")
    res = _run(tmp_path, "same", {"x": one, "y": one, "z": two})
    for comp in "xyz":
        _expect_y(res.frame, comp, 2.0, 1.0)
    # one module object, instantiated three times in the order of the components
    assert sorted(res.frame[f"{c}.serial"].iloc[-1] for c in "xyz") == [0, 1, 2]
    assert "isolation" not in (tmp_path / "run_same" / "fmu.log").read_text()

    # an FMU loaded in isolation is loaded once too: a second instance and a second run reuse its module
    other = _fmu(tmp_path, "other", "IsoSame", "iso_same_pkg", gain=4.0, value=3.0)
    first = _run(tmp_path, "iso1", {"u": other, "v": other})
    second = _run(tmp_path, "iso2", {"w": other})
    _expect_y(first.frame, "u", 4.0, 3.0)
    _expect_y(second.frame, "w", 4.0, 3.0)
    serials = [first.frame["u.serial"].iloc[-1], first.frame["v.serial"].iloc[-1], second.frame["w.serial"].iloc[-1]]
    assert sorted(serials) == [0, 1, 2]


def test_isolated_loading_leaves_global_modules_and_path_as_they_were(tmp_path, monkeypatch):
    pkg = "iso_keep_pkg"
    _package(tmp_path / "installed", pkg, gain=5.0, value=50.0)
    monkeypatch.syspath_prepend(str(tmp_path / "installed"))
    import iso_keep_pkg.core       # noqa: F401  (late stays unimported in the global copy)
    fmu = _fmu(tmp_path, "fmu", "IsoKeep", pkg, gain=2.0, value=10.0)
    before_modules = {k: m for k, m in sys.modules.items() if k.startswith(pkg) or k == "IsoKeep"}
    before_path = list(sys.path)
    res = _run(tmp_path, "keep", {"k": fmu})
    _expect_y(res.frame, "k", 2.0, 10.0)       # do_step imported the FMU's late module ...
    after = {k: m for k, m in sys.modules.items() if k.startswith(pkg) or k == "IsoKeep"}
    assert after == before_modules             # ... and none of its modules entered sys.modules
    assert sys.path == before_path
    # the FMU's own modules, kept for it: its slave module imported its bundled package
    resources = load_fmu(fmu).unzip_dir / "resources"
    module, clashes = load_slave_module(str(resources), "IsoKeep")
    assert clashes == [pkg]
    bundled = getattr(module, pkg)
    assert bundled.core.GAIN == 2.0 and bundled.late.VALUE == 10.0 and bundled is not sys.modules[pkg]
    import pythonfmu
    assert issubclass(module.IsoKeep, pythonfmu.Fmi2Slave)     # pythonfmu stays the installed one

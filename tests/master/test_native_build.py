"""master.native_build: C compiled once per content into the cache, the reason given when it cannot be."""
import ctypes
import os
import shutil

import pytest

from master import native_build

SOURCE = "double twice(double x) { return 2.0 * x; }\n"
FLAGS = ["-O2", "-fPIC", "-shared"]


NO_COMPILER = not (os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc"))
needs_cc = pytest.mark.skipif(NO_COMPILER, reason="no C compiler ($CC, cc, gcc): nothing to build with")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


@needs_cc
def test_built_once_and_rebuilt_when_the_source_changes(tmp_path, cache):
    src = tmp_path / "twice.c"
    src.write_text(SOURCE)
    first, why = native_build.compile_cached(src, "twice", "probe", FLAGS)
    assert why is None and first.parent == cache / "probe"
    lib = ctypes.CDLL(str(first))
    lib.twice.restype, lib.twice.argtypes = ctypes.c_double, [ctypes.c_double]
    assert lib.twice(21.0) == 42.0
    stamp = first.stat().st_mtime_ns
    again, _ = native_build.compile_cached(src, "twice", "probe", FLAGS)
    assert again == first and again.stat().st_mtime_ns == stamp       # taken from the cache, not rebuilt
    src.write_text(SOURCE.replace("2.0", "3.0"))
    edited, _ = native_build.compile_cached(src, "twice", "probe", FLAGS)
    assert edited != first and edited.is_file()
    assert sorted(p.name for p in (cache / "probe").iterdir()) == sorted([first.name, edited.name])  # no temp left


def test_without_a_compiler_the_reason_is_given(tmp_path, cache, monkeypatch):
    src = tmp_path / "twice.c"
    src.write_text(SOURCE)
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    path, why = native_build.compile_cached(src, "twice", "probe", FLAGS, what="the probe")
    assert path is None and "cannot compile the probe" in why


@needs_cc
def test_a_compile_error_is_reported_with_its_first_line(tmp_path, cache):
    src = tmp_path / "broken.c"
    src.write_text("double twice(double x) { return 2.0 * ; }\n")
    path, why = native_build.compile_cached(src, "broken", "probe", FLAGS)
    assert path is None and why.startswith("the C compiler failed:") and "broken.c" in why
    assert not list((cache / "probe").glob("*.so"))


@needs_cc
def test_an_extension_module_is_built_and_imported(tmp_path, cache):
    src = tmp_path / "probe_ext.c"
    src.write_text('#include <Python.h>\n'
                   'static PyObject *twice(PyObject *s, PyObject *x) { return PyFloat_FromDouble(2.0 * PyFloat_AsDouble(x)); }\n'
                   'static PyMethodDef M[] = {{"twice", twice, METH_O, ""}, {NULL, NULL, 0, NULL}};\n'
                   'static struct PyModuleDef D = {PyModuleDef_HEAD_INIT, "_probe_ext", NULL, -1, M};\n'
                   'PyMODINIT_FUNC PyInit__probe_ext(void) { return PyModule_Create(&D); }\n')
    module, why = native_build.compile_extension(src, "_probe_ext", "probe", FLAGS)
    if module is None and why.startswith("no Python.h"):
        pytest.skip(why)
    assert why is None and module.twice(1.5) == 3.0

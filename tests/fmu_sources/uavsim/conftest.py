"""Fixtures of the UAV model tests: both twins of the hot loops (uavsim.kernels)."""
import shutil

import pytest
from build_script import build_fmus_module


@pytest.fixture(scope="session")
def compiled_kernels(tmp_path_factory):
    """uavsim.kernels.Kernels of kernels.c compiled here (as build_fmus.py compiles it for the FMUs)."""
    import os

    from uavsim import kernels
    compile_kernels = build_fmus_module().compile_kernels
    if shutil.which(os.environ.get("CC", "gcc")) is None:
        pytest.skip("no C compiler: the compiled kernels cannot be built here")
    folder = tmp_path_factory.mktemp("kernels")
    assert compile_kernels(folder) is not None
    k = kernels.load(folder)
    assert k.compiled, "the compiled kernels did not load"
    return k


@pytest.fixture(scope="session")
def extensions_folder(tmp_path_factory):
    """A folder holding every uavsim/_*_ext.c compiled here, as build_fmus.py compiles them for the FMUs (once per
    session: each extension's tests load their module from it)."""
    import os
    if shutil.which(os.environ.get("CC", "gcc")) is None:
        pytest.skip("no C compiler: the extensions cannot be built here")
    folder = tmp_path_factory.mktemp("ext")
    if not build_fmus_module().compile_extensions(folder):
        pytest.skip("no Python headers: the extensions cannot be built here")
    return folder


@pytest.fixture(params=["python", "compiled"])
def any_kernels(request):
    """Each twin in turn."""
    from uavsim import kernels
    if request.param == "python":
        return kernels.Kernels(None)
    return request.getfixturevalue("compiled_kernels")

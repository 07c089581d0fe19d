"""The compiled lat/lon/alt getters (uavsim/_dynamics_ext.c) on a shell that is not complete yet.

pythonfmu registers ``lat`` with ``hasattr(shell, "lat")`` while the shell's __init__ is still running, before
its ENU frame exists. The getter must then raise AttributeError, as the Python property does, so that hasattr
answers False. It returned NULL with no exception set instead (a later attribute look-up cleared the first one's
error), which Python turns into "SystemError: <built-in function lat> returned NULL without setting an
exception": the UAV FMUs then failed to instantiate, depending on what the process had loaded before (seen in
OMSimulator and, now and then, in this suite)."""
import pytest

from uavsim.accelerators import DynamicsStep


class _Position:
    """x as a Python property (its look-up runs Python code, which suppresses and clears AttributeErrors)."""
    y = 2.0
    z = 3.0

    @property
    def x(self):
        return getattr(self, "no_such_field", 1.0)


@pytest.fixture(scope="module")
def shell_class():
    impl, why = DynamicsStep().load()
    if impl is None:
        pytest.skip(f"the compiled dynamics step is not available here: {why}")
    return impl[0]


@pytest.mark.parametrize("name", ["lat", "lon", "alt"])
def test_a_shell_without_its_frame_has_no_geodetic_value(shell_class, name):
    getter = getattr(shell_class, name).fget
    assert type(getter).__name__ == "builtin_function_or_method"      # the compiled getter, not the Python one
    with pytest.raises(AttributeError):
        getter(_Position())
    assert not hasattr(_Position(), name)

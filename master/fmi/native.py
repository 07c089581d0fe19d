"""What FMI 2.0 and 3.0 instances behind a C API share: state and end-of-life calls, by function name."""
from __future__ import annotations

from ctypes import byref, c_void_p

from .slave import OK, Slave


class NativeSlave(Slave):
    """A slave whose ``self._f`` is the FMU's function table and ``self.c`` its instance; subclasses name the
    functions (FMI 2.0 and 3.0 differ in prefix and in the spelling of FMUstate)."""
    GET_STATE = SET_STATE = FREE_STATE = TERMINATE = FREE_INSTANCE = ""

    def raw_function(self, name: str):
        """The FMU's C function ``name`` (e.g. "fmi2DoStep") as ctypes holds it, called without argument
        conversion: what the bound getters, setters and steps wrap, and what a step driver in C calls itself."""
        return self.lib.raw(name)

    def save_state(self, t=None):
        if not self.can_save_state:
            return super().save_state(t)
        state = c_void_p()
        self.check(self.GET_STATE, self._f[self.GET_STATE](self.c, byref(state)), t)
        return state

    def restore_state(self, token, t=None):
        if not self.can_save_state:
            return super().restore_state(token, t)
        self.check(self.SET_STATE, self._f[self.SET_STATE](self.c, token), t)

    def release_state(self, token):
        if token is not None and self.instantiated:
            self._f[self.FREE_STATE](self.c, byref(token))

    def terminate(self):
        if self.initialized:
            self.initialized = False
            return self._f[self.TERMINATE](self.c)
        return OK

    def free(self):
        if self.instantiated:
            self.instantiated = False
            self._f[self.FREE_INSTANCE](self.c)

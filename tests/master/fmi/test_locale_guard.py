"""An FMU that calls the C library's setlocale(LC_ALL, "C") (OpenModelica's runtime does, on load) must not leave
the master's process unable to read or write UTF-8 text: the embrace FMUs did, and every later report read failed."""
import ctypes
import ctypes.util
import locale

import pytest

from master.fmi.locale_guard import keep_character_type

LC_ALL = 6          # glibc's value; the test runs where glibc is the C library


@pytest.fixture
def libc():
    name = ctypes.util.find_library("c")
    if name is None or locale.setlocale(locale.LC_CTYPE) in ("C", "POSIX"):
        pytest.skip("needs glibc and a process started in a UTF-8 locale")
    lib = ctypes.CDLL(name)
    lib.setlocale.restype = ctypes.c_char_p
    before = locale.setlocale(locale.LC_ALL)
    yield lib
    locale.setlocale(locale.LC_ALL, before)


def test_a_foreign_setlocale_keeps_the_character_type(libc, tmp_path):
    encoding = locale.getpreferredencoding(False)
    with keep_character_type():
        libc.setlocale(LC_ALL, b"C")       # what such an FMU does behind Python's back
        assert locale.getpreferredencoding(False) != encoding
    assert locale.getpreferredencoding(False) == encoding
    p = tmp_path / "t.md"
    p.write_text("−5 °C")
    assert p.read_text() == "−5 °C"
    assert locale.setlocale(locale.LC_NUMERIC) == "C"   # the FMU's own numeric choice stays

"""Keep the process's character encoding across calls into FMUs.

Some FMUs (OpenModelica's runtime among them, e.g. OMSimulator's test-suite FMUs) call ``setlocale(LC_ALL, "C")``
when they are loaded or instantiated.  That switches the whole process's character type to ASCII, and every later
``open()`` without an explicit encoding (the report, run.json notes, the user's own notebook code) fails on UTF-8
text.  The FMU keeps the numeric locale it chose; only the character type is put back.
"""
from __future__ import annotations

import contextlib
import locale


@contextlib.contextmanager
def keep_character_type():
    before = locale.setlocale(locale.LC_CTYPE)
    try:
        yield
    finally:
        if locale.setlocale(locale.LC_CTYPE) != before:
            locale.setlocale(locale.LC_CTYPE, before)

"""Folders and files named for the process that owns them, and the sweep of those whose process is gone.

A process that unpacks scenarios (a supervised run's simulation process, a campaign's worker) does so in a scratch
folder ``<prefix><pid>-...`` that its owner removes when it is done with it. A process killed with SIGKILL removes
nothing; the next process of the same kind sweeps what such processes left (:func:`sweep_left`), and only entries
named for a process that no longer runs: the temporary folder is everyone's.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time


def make(prefix: str, folder: str | None = None) -> str:
    """A new folder ``<prefix><this pid>-<random>`` in ``folder`` (default: the temporary folder)."""
    return tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}-", dir=folder)


def sweep_left(folder: str, prefix: str, unnamed_age_s: float | None) -> list[str]:
    """Removes ``folder``'s entries named ``prefix<pid>-...`` whose process is gone, and (``unnamed_age_s``) those
    named for no process once they are that old; returns their names."""
    try:
        names = [n for n in os.listdir(folder) if n.startswith(prefix)]
    except OSError:
        return []
    swept = []
    for name in names:
        path = os.path.join(folder, name)
        pid = name[len(prefix):].split("-", 1)[0]
        if not pid.isdigit():
            try:
                if unnamed_age_s is None or time.time() - os.stat(path).st_mtime < unnamed_age_s:
                    continue
            except OSError:
                continue
        elif int(pid) == os.getpid():
            continue
        else:
            try:
                os.kill(int(pid), 0)
                continue                    # alive (its entry is in use)
            except ProcessLookupError:
                pass
            except PermissionError:         # alive, another user's
                continue
        try:
            if os.path.isdir(path) and not os.path.islink(path):
                shutil.rmtree(path)
            else:
                os.unlink(path)
            swept.append(name)
        except OSError:                 # another process swept it first, or not ours to remove
            pass
    return swept

"""FMU log messages, captured per component and filtered by the user's --log-level."""
from __future__ import annotations

import sys
import threading

LEVELS = {"debug": 0, "info": 1, "warning": 2, "error": 3, "none": 4}
# FMI status codes (same numbers in FMI 2.0 and 3.0) to log levels
STATUS_LEVEL = {0: "info", 1: "warning", 2: "error", 3: "error", 4: "error", 5: "info"}
STATUS_NAME = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}


class LogSink:
    """Collects messages; the last error of each component is kept to explain a failed call."""

    def __init__(self, level: str = "warning", stream=None, file=None):
        self.threshold = LEVELS[level]
        self.stream = stream if stream is not None else sys.stderr
        self.file = file
        self.last_error: dict[str, str] = {}
        self.counts = {name: 0 for name in LEVELS}
        self._lock = threading.Lock()

    def message(self, component: str, level: str, text: str, category: str = "") -> None:
        text = " ".join(str(text).split())
        with self._lock:
            self.counts[level] += 1
            if level == "error":
                self.last_error[component] = text
            line = f"[{level}] {component}{'/' + category if category else ''}: {text}"
            if self.file is not None:
                self.file.write(line + "\n")
            if LEVELS[level] >= self.threshold:
                print(line, file=self.stream)

    def pop_error(self, component: str) -> str | None:
        return self.last_error.pop(component, None)

    def close(self):
        if self.file is not None:
            self.file.close()
            self.file = None

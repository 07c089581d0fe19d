"""The references a study compares its runs with.

- ``analytic:MODULE:FUNCTION``: a Python function of time (a numpy array) returning the signals, a mapping
  'component.variable' -> array (or a pandas DataFrame); MODULE is a file (``ssp/coupling/oscillator_exact.py``)
  or an importable module name;
- ``fine:H``: the same scenario co-simulated with a second-order scheme, iterative coupling with inputs
  interpolated over the step (``coupling_interpolation`` 1: the trapezoidal coupled step), at the step H and at
  H / 2 (two runs of the study's campaign). The run at H / 2 is the reference; its error is estimated by
  Richardson's rule from the two, max |y_H - y_{H/2}| / (2^2 - 1) per signal (Hairer, Noersett and Wanner I,
  sec. II.4); where a run's times fall between the reference's samples the bound of linear interpolation,
  h^2/8 max |y''| taken as max |second difference| / 6, is added (choose H / 2 dividing the studied steps and there is none). The FMUs'
  own integration error is part of both runs and not estimated (the coupling benchmarks'
  FMUs integrate exactly for held inputs); a scenario whose FMUs cannot save their state cannot be iterated:
  give a results file or a closed form instead;
- a results file (``.parquet`` or ``.csv`` with a ``time`` column, e.g. another run's results.parquet): its
  error is unknown.

Runs are compared at their own recorded times; a reference given as samples (fine, file) is interpolated
linearly there (exact where the run's times are among the reference's, as for a fine step dividing the
run's step).
"""
from __future__ import annotations

import importlib
import importlib.util
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import CosimError

ELEMENT = "--reference"
#: the scheme of a ``fine:`` reference: its campaign run parameters besides the step, and its global order
FINE_SCHEME = {"algorithm": "iterative", "extrapolation": 0, "coupling_interpolation": 1}
FINE_ORDER = 2


@dataclass
class Reference:
    kind: str                   # "analytic", "fine", "file"
    text: str                   # as given
    function: object = None     # analytic: f(t) -> {signal: array}
    fine_step: float | None = None
    frame: object = None        # file (and fine, once its run is done): pandas DataFrame with "time"
    errors: dict | None = None  # signal -> the reference's own estimated error (analytic: 0, file: unknown)
    curvature: dict | None = None   # fine: signal -> max |second difference| of its samples (interpolation bound)

    def runs(self) -> list[dict]:
        """The campaign runs a fine reference needs: at H and at H / 2."""
        if self.kind != "fine":
            return []
        return [{**FINE_SCHEME, "step": self.fine_step}, {**FINE_SCHEME, "step": self.fine_step / 2}]

    def describe(self) -> str:
        """What the reference is, for study.csv and the figures."""
        if self.kind == "fine":
            return (f"{self.text}: iterative, trapezoidal inputs (order {FINE_ORDER}) at {self.fine_step / 2:g} s, "
                    f"error estimated from {self.fine_step:g} s")
        if self.kind == "analytic":
            return f"{self.text} (closed form)"
        return f"{self.text} (results file, error unknown)"

    def error(self, signal: str, t: np.ndarray | None = None) -> float:
        """The reference's own estimated error of ``signal`` at the times ``t``: for a fine reference its
        estimate plus, where some of ``t`` fall between its samples, the bound of linear interpolation,
        h^2/8 max |y''|, as max |second difference| / 6 (a third more: |y''| may peak between samples)."""
        if self.kind == "analytic":
            return 0.0
        e = (self.errors or {}).get(signal, math.nan)
        if t is not None and self.kind == "fine" and not self.on_grid(t):
            e += self.curvature.get(signal, math.nan) / 6
        return e

    def on_grid(self, t: np.ndarray) -> bool:
        """Whether every time of ``t`` is one of the reference's sample times (within round-off)."""
        ref_t = self.frame["time"].to_numpy(dtype=float)
        i = np.clip(np.searchsorted(ref_t, t), 1, len(ref_t) - 1)
        nearest = np.minimum(np.abs(ref_t[i] - t), np.abs(ref_t[i - 1] - t))
        return bool(np.all(nearest <= 1e-9 * max(1.0, abs(ref_t[-1]))))

    def set_fine(self, coarse, fine) -> None:
        """The fine reference from its runs at H (``coarse``) and H / 2 (``fine``, DataFrames): the values of
        the finer one, the error estimate from their difference at the coarser one's times."""
        self.frame = fine
        t = coarse["time"].to_numpy(dtype=float)
        self.errors = {}
        self.curvature = {s: float(np.max(np.abs(np.diff(fine[s].to_numpy(dtype=float), 2)), initial=0.0))
                          for s in fine.columns if s != "time"}
        for s in coarse.columns:
            if s == "time" or s not in fine.columns:
                continue
            d = coarse[s].to_numpy(dtype=float) - np.interp(t, fine["time"].to_numpy(dtype=float),
                                                            fine[s].to_numpy(dtype=float))
            self.errors[s] = float(np.max(np.abs(d))) / (2 ** FINE_ORDER - 1) if len(d) else math.nan

    def values(self, t: np.ndarray, signals: list[str]) -> dict[str, np.ndarray]:
        """The reference's value of each of ``signals`` it knows at the times ``t``."""
        if self.kind == "analytic":
            try:
                out = self.function(np.asarray(t, dtype=float))
            except Exception as exc:   # noqa: BLE001 - the user's function: say which and why, one line
                raise CosimError(f"{self.text} failed: {type(exc).__name__}: {exc}", element=ELEMENT) from None
            return {s: np.broadcast_to(np.asarray(out[s], dtype=float), t.shape) for s in signals if s in out}
        df = self.frame
        ref_t = df["time"].to_numpy(dtype=float)
        return {s: np.interp(t, ref_t, df[s].to_numpy(dtype=float)) for s in signals if s in df.columns}

    def covers(self, t: np.ndarray) -> np.ndarray:
        """Which of the times ``t`` the reference covers (a sampled reference: within its time range)."""
        if self.kind == "analytic":
            return np.ones(len(t), dtype=bool)
        ref_t = self.frame["time"].to_numpy(dtype=float)
        tol = 1e-9 * max(1.0, abs(ref_t[-1]))
        return (t >= ref_t[0] - tol) & (t <= ref_t[-1] + tol)


def parse_reference(text: str) -> Reference:
    """A reference from its command-line text; a one-line CosimError when it cannot be used."""
    text = str(text).strip()
    if text.startswith("analytic:"):
        spec = text[len("analytic:"):]
        module_name, sep, func = spec.rpartition(":")
        if not sep or not module_name or not func:
            raise CosimError(f"expected analytic:MODULE:FUNCTION, got {text!r}", element=ELEMENT)
        module = _load_module(module_name, text)
        fn = getattr(module, func, None)
        if not callable(fn):
            raise CosimError(f"{module_name} has no function {func!r}", element=ELEMENT)
        return Reference("analytic", text, function=fn)
    if text.startswith("fine:"):
        try:
            h = float(text[len("fine:"):])
        except ValueError:
            h = float("nan")
        if not (math.isfinite(h) and h > 0):
            raise CosimError(f"expected fine:H with a positive step H in seconds, got {text!r}", element=ELEMENT)
        return Reference("fine", text, fine_step=h)
    path = Path(text)
    if path.suffix.lower() not in (".parquet", ".csv"):
        raise CosimError(f"expected analytic:MODULE:FUNCTION, fine:H or a results file (.parquet, .csv), "
                         f"got {text!r}", element=ELEMENT)
    if not path.is_file():
        raise CosimError(f"results file not found: {path}", element=ELEMENT)
    return Reference("file", text, frame=read_samples(path, ELEMENT))


def read_samples(path: Path, element: str):
    """A results file as a DataFrame sorted by time, checked for a numeric ``time`` column."""
    import pandas as pd
    try:
        df = pd.read_parquet(path) if path.suffix.lower() == ".parquet" else pd.read_csv(path)
    except Exception as exc:   # noqa: BLE001 - any unreadable file is the same one-line error
        raise CosimError(f"cannot read {path}: {type(exc).__name__}: {exc}", element=element) from None
    if "time" not in df.columns or len(df) == 0:
        raise CosimError(f"{path} has no 'time' column or no rows", element=element)
    return df.sort_values("time", kind="stable").reset_index(drop=True)


def _load_module(name: str, text: str):
    path = Path(name)
    if name.endswith(".py"):
        if not path.is_file():
            raise CosimError(f"module file not found: {path}", element=ELEMENT)
        module_name = f"cosim_study_reference_{abs(hash(str(path.resolve())))}"
        spec = importlib.util.spec_from_file_location(module_name, path)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:   # noqa: BLE001
            raise CosimError(f"cannot load {path}: {type(exc).__name__}: {exc}", element=ELEMENT) from None
        return module
    if "" not in sys.path and str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        return importlib.import_module(name)
    except Exception as exc:   # noqa: BLE001
        raise CosimError(f"cannot import {name!r} ({text}): {type(exc).__name__}: {exc}", element=ELEMENT) from None

"""The strategy's mission data (targets, restricted zones) as indexed scalar Integer/Real parameters.

Why: FMI masters do not all apply String parameters from an SSP (Ecos 0.7 ignores them, so a UAV
given its targets only as the String ``targets`` takes off and lands at once); every master applies
Integer and Real ones.  FMI 2.0 has no array variables, so each coordinate is its own scalar:

* ``n_targets`` (Integer), ``target_x_<k>``, ``target_y_<k>`` (Real, m ENU), k = 1..n_targets;
* ``n_zones`` (Integer), ``zone_<z>_n_vertices`` (Integer), ``zone_<z>_x_<j>``, ``zone_<z>_y_<j>``
  (Real, m ENU), z = 1..n_zones, j = 1..zone_<z>_n_vertices.

Names are flat (letters, digits, underscores; 1-based like the SSP/FMI value references people read):
no brackets, because cosim-master's record patterns and ``--set`` selectors are shell-style globs in
which ``[1]`` is a character class.  ``n_targets`` / ``n_zones`` = -1 (the default) means "not given":
the String form (``targets`` / ``zones``) is used instead.  When both are given the indexed form wins
for that item: it is the one every master applies, so a scenario then means the same in all masters.
"""
from __future__ import annotations

from typing import Callable, Iterable, Sequence

MAX_TARGETS = 64
MAX_ZONES = 16
MAX_ZONE_VERTICES = 32
MIN_ZONE_VERTICES = 3
NOT_GIVEN = -1            # n_targets / n_zones default: use the String form

Point = tuple[float, float]


def target_names(k: int) -> tuple[str, str]:
    """Names of the x and y parameters of target k (1-based)."""
    return f"target_x_{k}", f"target_y_{k}"


def zone_count_name(z: int) -> str:
    """Name of the vertex count of zone z (1-based)."""
    return f"zone_{z}_n_vertices"


def zone_vertex_names(z: int, j: int) -> tuple[str, str]:
    """Names of the x and y parameters of vertex j of zone z (both 1-based)."""
    return f"zone_{z}_x_{j}", f"zone_{z}_y_{j}"


def limit_errors(n_targets: int, zone_sizes: Sequence[int]) -> list[str]:
    """Why a mission does not fit the indexed parameters (empty when it fits)."""
    errors = []
    if not 0 <= n_targets <= MAX_TARGETS:
        errors.append(f"{n_targets} targets (the strategy FMU takes 0..{MAX_TARGETS})")
    if len(zone_sizes) > MAX_ZONES:
        errors.append(f"{len(zone_sizes)} zones (the strategy FMU takes at most {MAX_ZONES})")
    for z, size in enumerate(zone_sizes[:MAX_ZONES], start=1):
        if not MIN_ZONE_VERTICES <= size <= MAX_ZONE_VERTICES:
            errors.append(f"zone {z} has {size} vertices (the strategy FMU takes "
                          f"{MIN_ZONE_VERTICES}..{MAX_ZONE_VERTICES} per zone)")
    return errors


def check_limits(n_targets: int, zone_sizes: Sequence[int]) -> None:
    errors = limit_errors(n_targets, zone_sizes)
    if errors:
        raise ValueError("mission exceeds the strategy FMU's parameters: " + "; ".join(errors))


def encode(targets: Sequence[Point], zones: Sequence[Sequence[Point]]) -> dict[str, int | float]:
    """The parameter values that give the strategy these targets and zones (ValueError beyond the maxima)."""
    check_limits(len(targets), [len(z) for z in zones])
    values: dict[str, int | float] = {"n_targets": len(targets)}
    for k, (x, y) in enumerate(targets, start=1):
        nx, ny = target_names(k)
        values[nx], values[ny] = float(x), float(y)
    values["n_zones"] = len(zones)
    for z, polygon in enumerate(zones, start=1):
        values[zone_count_name(z)] = len(polygon)
        for j, (x, y) in enumerate(polygon, start=1):
            nx, ny = zone_vertex_names(z, j)
            values[nx], values[ny] = float(x), float(y)
    return values


def _given_count(get: Callable[[str], float], name: str, most: int) -> int | None:
    """The value of count parameter ``name``: None when NOT_GIVEN, ValueError outside 0..most."""
    n = int(get(name))
    if n == NOT_GIVEN:
        return None
    if not 0 <= n <= most:
        raise ValueError(f"{name} = {n}: the strategy FMU takes {NOT_GIVEN} (not given) or 0..{most}")
    return n


def decode_targets(get: Callable[[str], float]) -> list[Point] | None:
    """Targets from the parameter values (``get(name)``), or None when ``n_targets`` is not given."""
    n = _given_count(get, "n_targets", MAX_TARGETS)
    if n is None:
        return None
    return [(float(get(nx)), float(get(ny))) for nx, ny in map(target_names, range(1, n + 1))]


def decode_zones(get: Callable[[str], float]) -> list[list[Point]] | None:
    """Zone polygons from the parameter values, or None when ``n_zones`` is not given."""
    n = _given_count(get, "n_zones", MAX_ZONES)
    if n is None:
        return None
    sizes = [int(get(zone_count_name(z))) for z in range(1, n + 1)]
    check_limits(0, sizes)
    return [[(float(get(nx)), float(get(ny))) for nx, ny in (zone_vertex_names(z, j) for j in range(1, size + 1))]
            for z, size in enumerate(sizes, start=1)]


def parameter_names() -> Iterable[tuple[str, str]]:
    """(name, type) of every indexed parameter, in the order the FMU declares them."""
    yield "n_targets", "Integer"
    for k in range(1, MAX_TARGETS + 1):
        for name in target_names(k):
            yield name, "Real"
    yield "n_zones", "Integer"
    for z in range(1, MAX_ZONES + 1):
        yield zone_count_name(z), "Integer"
        for j in range(1, MAX_ZONE_VERTICES + 1):
            for name in zone_vertex_names(z, j):
                yield name, "Real"

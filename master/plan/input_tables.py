"""Input tables (``fmi/table.py``) in a plan: an SSD component of type text/csv, and ``run --input FILE``; each
stands in for an FMU whose outputs are its connected columns, typed as the inputs they drive."""
from __future__ import annotations

from pathlib import Path

from ..errors import ScenarioError
from ..log import warning
from ..ssp.model import CSV_SOURCE_TYPE, Component, Connection, Connector, SystemModel
from .checks import check_connector
from .model import Var, shown_source
from .variable_values import value_error


INPUT_FILE_COMPONENT = "inputs"


def add_input_file(model: SystemModel, path: Path, variables: dict, shown_as: str, lenient: bool = False) -> None:
    """``run --input FILE``: the file as an input table whose columns drive the inputs of the scenario's one FMU
    of the same names. A column that names no input is a typo until the user says otherwise: ``lenient`` (``run
    --lenient``) ignores such columns with a warning naming them (the Reference FMUs ship one ``Feedthrough_in.csv``
    for FMI 2.0 and 3.0, whose FMI 2.0 model lacks the FMI 3.0 types)."""
    from ..fmi.table import read_csv_table       # (with the csv module: only a scenario with input tables reads one)
    targets = [name for name, comp in model.components.items() if comp.type != CSV_SOURCE_TYPE]
    if len(targets) != 1:
        raise ScenarioError(f"--input drives the inputs of a scenario with one FMU; this one has {len(targets)} "
                            f"({', '.join(targets)})", file=shown_as, element="--input")
    if INPUT_FILE_COMPONENT in model.components:
        raise ScenarioError(f"the scenario has a component named {INPUT_FILE_COMPONENT!r} already, the name --input "
                            "gives its table", file=shown_as, element="--input")
    target, columns = targets[0], list(read_csv_table(path, str(path)).columns)
    inputs = sorted(n for n, v in variables[target].items() if v.causality == "input" and not v.is_array)
    unknown = [c for c in columns if c not in inputs]
    if unknown and not lenient:
        raise ScenarioError(_unknown_columns(unknown, target, inputs), file=str(path), element="--input")
    if unknown:
        warning(
            "%s: --input: ignoring column%s %s, which name%s no input of %s (--lenient)", path,
            "s" if len(unknown) > 1 else "", ", ".join(unknown), "" if len(unknown) > 1 else "s", target)
        columns = [c for c in columns if c in inputs]
    model.components[INPUT_FILE_COMPONENT] = Component(INPUT_FILE_COMPONENT, str(path), path, CSV_SOURCE_TYPE,
                                                       {c: Connector(c, "output") for c in columns})
    model.connections += [Connection(INPUT_FILE_COMPONENT, c, target, c) for c in columns]


def _unknown_columns(unknown: list[str], target: str, inputs: list[str]) -> str:
    """What is wrong with the columns that name no input, the inputs they may have meant, and the way past."""
    import difflib
    # close enough to be a slip of the keyboard; Int8_input is not a misspelt Int32_input
    near = {c: difflib.get_close_matches(c, inputs, n=1, cutoff=0.9) for c in unknown}
    named = [f"{c!r} (did you mean {m[0]!r}?)" if m else repr(c) for c, m in near.items()]
    named = named[:5] + ([f"{len(named) - 5} more"] if len(named) > 5 else [])
    return (f"{len(unknown)} column{'s' if len(unknown) > 1 else ''} name{'' if len(unknown) > 1 else 's'} no input "
            f"of {target}: {', '.join(named)} (its inputs: {', '.join(inputs) or 'none'}); --lenient ignores "
            "such columns with a warning")


def csv_component(name: str, comp: Component, model: SystemModel, variables: dict, shown_as: str):
    """An input table's stand-in for an FMU and its variables: one per connected column, typed as the input it
    drives and interpolated as that input's variability asks (linear for a continuous Real, else hold)."""
    from ..fmi.table import TableColumn, column_values, csv_source, read_csv_table
    # the --input file is named as the user gave it, not as a member of the scenario
    shown = comp.source if name == INPUT_FILE_COMPONENT else shown_source(shown_as, comp.source)
    table = read_csv_table(comp.fmu_path, shown)
    for conn in comp.connectors.values():
        if conn.name not in table.columns:
            raise ScenarioError(f"the input table {comp.source} has no column {conn.name!r} (its columns: "
                                f"{', '.join(table.columns)})", file=shown_as,
                                element=f"Connector {name}.{conn.name}", line=conn.line)
    out, columns = {}, []
    for vr, (column, driven) in enumerate(_driven_inputs(name, model, variables, shown_as).items()):
        if column not in table.columns:
            raise ScenarioError(f"the input table {comp.source} has no column {column!r}", file=shown_as,
                                element=f"Connection {name}.{column} -> {driven[0].qualified}")
        v = out[column] = _column_var(name, column, vr, driven, shown_as)
        if column in comp.connectors:
            check_connector(comp.connectors[column], v, shown_as)
        values = column_values(table, column, v.type, shown)
        why = next((w for w in (value_error(v, x, allow_nonfinite=True) for x in values) if w), None)
        if why:
            raise ScenarioError(why, file=shown)
        columns.append(TableColumn(vr, values, linear=v.variability == "continuous"))
    return csv_source(table, columns), out


def _driven_inputs(name: str, model: SystemModel, variables: dict, shown_as: str) -> dict[str, list[Var]]:
    """Column -> the FMU variables the table's connections drive from it."""
    driven: dict[str, list[Var]] = {}
    for c in model.connections:
        if c.src_component != name:
            continue
        dst = variables.get(c.dst_component, {}).get(c.dst_connector)
        if dst is None:
            raise ScenarioError(f"component {c.dst_component!r} has no variable {c.dst_connector!r}", file=shown_as,
                                element=f"Connection {c.src} -> {c.dst}", line=c.line)
        driven.setdefault(c.src_connector, []).append(dst)
    return driven


def _column_var(name: str, column: str, vr: int, driven: list[Var], shown_as: str) -> Var:
    """A column as an output of the type of the inputs it drives; continuous when it drives a continuous Real
    (interpolated linearly), discrete otherwise (held). Inputs of other types or variabilities need columns of
    their own."""
    def how(v):
        return v.fmi_type, "continuous" if v.type == "Real" and v.variability == "continuous" else "discrete"
    first = driven[0]
    other = next((v for v in driven if how(v) != how(first)), None)
    if other is not None:
        raise ScenarioError(f"column {column!r} drives {first.qualified} ({' '.join(how(first))}) and "
                            f"{other.qualified} ({' '.join(how(other))}): give each its own column",
                            file=shown_as, element=f"Component {name}")
    return Var(name, column, vr, first.type, first.fmi_type, "output", how(first)[1], first.unit)

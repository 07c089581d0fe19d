"""The plan: a parsed system checked against its FMUs and resolved to value references, before anything runs.

* :mod:`.model` -- what a plan is made of (``Var``, ``Link``, ``Plan``);
* :mod:`.build` -- ``build_plan``: the SSD against the FMUs' modelDescriptions, connections resolved to links;
* :mod:`.variables` -- an FMU's variables as ``Var`` objects, described once per FMU;
* :mod:`.checks` -- a connector against its variable, a connection against its two ends;
* :mod:`.variable_values`, :mod:`.parameters` -- the values variables take, and those the SSD and the command
  line give them;
* :mod:`.input_tables` -- CSV input tables standing in for FMUs;
* :mod:`.reuse` -- the value-free part of a plan kept for later runs of the same structure.

The names below are the plan's face for the rest of the engine; modules of this package import each other, never
this file.
"""
from .build import build_plan
from .checks import KIND_CAUSALITY, SSD_TYPE_FMI
from .input_tables import INPUT_FILE_COMPONENT
from .model import ComponentVariables, Link, Plan, Var, element_names, shown_source
from .parameters import add_overrides
from .variable_values import INT_RANGES, parse_value, value_error

__all__ = ["build_plan", "add_overrides", "parse_value", "value_error", "shown_source", "element_names",
           "ComponentVariables", "Link", "Plan", "Var", "INT_RANGES", "INPUT_FILE_COMPONENT", "KIND_CAUSALITY",
           "SSD_TYPE_FMI"]

"""Loading FMUs and calling them through the FMI 2.0 / 3.0 C API."""

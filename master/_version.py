"""The package version, in a module of its own: run.json records it, and a module that needs it imports it from
here rather than from the package face (master/__init__), which sits on top of every other module."""
__version__ = "0.1.0"

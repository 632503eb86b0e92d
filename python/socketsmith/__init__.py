"""socketsmith: lower-limb prosthetic socket design from a residual-limb scan.

The C++ library behind the ``socketsmith`` command, from Python (docs/python.md)::

    import socketsmith
    d = socketsmith.design(socketsmith.demo_case(target_nodes=2000))
    d.radar            # [Fx, Fy, Fz, Tx, Ty, Tz, stability], as design.json
    d.pressure_pa      # applied pressure per skin node (a read-only NumPy view, no copy)

Cases are dicts with the case file's schema (docs/case_file.md) or paths of case files. Errors are
the CLI's, as exceptions: ``InvalidInputError`` (exit code 1), ``IoError`` (2), ``SolverError`` (3),
``TopologyError`` (4), ``InternalError`` (70), all ``socketsmith.Error``; ``str(e)`` is the line
the CLI prints after ``error:``. Long calls take ``progress=callable(fraction, stage)``; returning
False cancels. ``validate(case, out)`` checks a design in CalculiX (``socketsmith validate design``):
the metrics as ``Validation.summary``, the fields as NumPy views. The library logs warnings to
stderr: ``set_log_level("info")`` for more.
"""

from ._core import (  # noqa: F401  (the public API)
    Design,
    Donning,
    Error,
    InternalError,
    InvalidInputError,
    IoError,
    Mesh,
    SolverError,
    Stump,
    TopologyError,
    Validation,
    check_mesh,
    demo_case,
    design,
    normalise_case,
    prepare,
    read_mesh,
    set_log_level,
    solve,
    validate,
)

RADAR_AXES = ("fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm", "stability_n")
"""The order of Design.radar, with design.json's keys."""

__all__ = [
    "Design", "Donning", "Error", "InternalError", "InvalidInputError", "IoError", "Mesh", "SolverError", "Stump",
    "TopologyError", "Validation", "check_mesh", "demo_case", "design", "normalise_case", "prepare", "read_mesh",
    "set_log_level", "solve", "validate", "RADAR_AXES",
]

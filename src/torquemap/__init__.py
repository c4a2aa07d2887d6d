"""torquemap: see through the torque of electric actuators.

Sensorless force estimation from motor currents and encoders, identification of friction and
position-dependent torque variations (PDTV), and torque-linearisation look-up tables.
See ``docs/conventions.md`` for units, sides and signs, and ``docs/api-example.md`` for the
Python API in one page:

>>> import torquemap
>>> robot = torquemap.robot_from_dict({"robot": {"kinematics": "none"},
...     "joints": {"m": {"gear_ratio": 1, "torque_constant": 0.1}}})
>>> robot.joint_names
('m',)

The names below are loaded on first use, so ``import torquemap`` stays fast.
``identify``, ``estimate`` and ``pdtv_map`` are modules that can be called like the functions of
:mod:`torquemap.api` they stand for.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> (module, attribute); attribute None: the module itself (a callable module).
_EXPORTS: dict[str, tuple[str, str | None]] = {
    "load_robot": ("torquemap.robot", "load_robot"),
    "robot_from_dict": ("torquemap.robot", "robot_from_dict"),
    "Robot": ("torquemap.robot", "Robot"),
    "Joint": ("torquemap.robot", "Joint"),
    "read_log": ("torquemap.io", "read_log"),
    "log_from_columns": ("torquemap.io", "log_from_columns"),
    "Log": ("torquemap.io", "Log"),
    "identify": ("torquemap.identify", None),
    "estimate": ("torquemap.estimate", None),
    "pdtv_map": ("torquemap.pdtv_map", None),
    "Identification": ("torquemap.identify", "Identification"),
    "ForceEstimate": ("torquemap.estimate", "ForceEstimate"),
    "PdtvMap": ("torquemap.pdtv_map", "PdtvMap"),
    "save_model": ("torquemap.model", "save_model"),
    "load_model": ("torquemap.model", "load_model"),
    "Model": ("torquemap.model", "Model"),
    "build_tables": ("torquemap.linearize.tables", "build_tables"),
    "InputError": ("torquemap.errors", "InputError"),
    "identify_quasi_static": ("torquemap.quasistatic", "identify_quasi_static"),
    "verify_cogging": ("torquemap.cogging", "verify_cogging"),
}

__all__ = [
    "ForceEstimate",
    "Identification",
    "InputError",
    "Joint",
    "Log",
    "Model",
    "PdtvMap",
    "Robot",
    "build_tables",
    "estimate",
    "identify",
    "identify_quasi_static",
    "load_model",
    "load_robot",
    "log_from_columns",
    "pdtv_map",
    "read_log",
    "robot_from_dict",
    "save_model",
    "verify_cogging",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers only
    from torquemap.api import estimate, identify, pdtv_map
    from torquemap.cogging import verify_cogging
    from torquemap.errors import InputError
    from torquemap.estimate import ForceEstimate
    from torquemap.identify import Identification
    from torquemap.io import Log, log_from_columns, read_log
    from torquemap.linearize.tables import build_tables
    from torquemap.model import Model, load_model, save_model
    from torquemap.pdtv_map import PdtvMap
    from torquemap.quasistatic import identify_quasi_static
    from torquemap.robot import Joint, Robot, load_robot, robot_from_dict


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'torquemap' has no attribute {name!r}")
    module_name, attribute = _EXPORTS[name]
    module = importlib.import_module(module_name)
    if attribute is None:
        return module  # made callable by itself (torquemap._callable)
    value = getattr(module, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})

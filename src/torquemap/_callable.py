"""Modules that can be called like the function they are named after.

``torquemap.identify`` and ``torquemap.estimate`` are modules (``torquemap.estimate.ForceEstimator``
and ``import torquemap.identify as m`` must keep working) and, at the top level, the public
functions :func:`torquemap.api.identify` and :func:`torquemap.api.estimate`. A package attribute
cannot be both, but a module object whose class defines ``__call__`` is: :func:`make_callable`
swaps the class of an already imported module for one that forwards calls to a function of
:mod:`torquemap.api` (imported at call time, so there is no import cycle).
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import Any


class CallableModule(types.ModuleType):
    """A module that forwards calls to ``__call_target__`` (``"module:function"``)."""

    __call_target__: str

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        """Call the function this module stands for (its docstring says which)."""
        module, _, name = self.__call_target__.partition(":")
        return getattr(importlib.import_module(module), name)(*args, **kwargs)


def make_callable(module_name: str, target: str) -> None:
    """Make the imported module ``module_name`` callable; calls go to ``target``.

    Parameters
    ----------
    module_name
        An imported module's ``__name__``.
    target
        ``"package.module:function"``, resolved at each call.
    """
    module = sys.modules[module_name]
    module.__class__ = CallableModule
    module.__call_target__ = target  # type: ignore[attr-defined]

"""The table builds of one test module, each computed once: what several tests read.

``build_tables`` and ``transfer_characterisation`` are deterministic functions of their
arguments (no random draw, clock or environment), and the linearisation tests call them
several times with the same rows: a library test and the CLI test of the same file, or a
test comparing a call with its default to the same call with that default spelt out. A test
module opts in with ``REUSE_BUILDS = True`` (conftest.py's ``_reused_builds``); its calls of
either function, the CLI's included, then run once per distinct argument set and module, and
every later call gets a deep copy of the first one's result (a test that changes the arrays it
got cannot change what another reads).

The key is every argument, defaults applied (a default spelt out is the same call), the arrays
by value, except the file names: ``path`` and the ``path`` of a ``MotorSpec`` or
``LinearizeData``, which only name the file in the ``InputError`` a call raises (tables.py,
transfer.py: they reach no result and no warning; the CLI prefixes the file name to the
warnings it prints itself). A call that raises is not kept: it raises afresh every time, with
its own file name.

A module with ``REUSE_BUILDS = "session"`` keeps them in ``SESSION`` instead, one memo for the
test process (an xdist worker's): the demo fixture (conftest.py, ``demo_run``) builds the
tutorial's rig tables in it, and test_tutorial's ``linearize build`` of the same rows, with the
same options, then reads them (both run on one worker, ``xdist_group("demo")``).

``REUSE_LOG=FILE`` appends ``hit`` or ``miss``, the function and the test to FILE.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import hashlib
import inspect
import os
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest


def _canonical(value: Any) -> Any:
    """``value`` as plain data (tuples, bytes, numbers, strings), equal for equal arguments: a
    dataclass as its fields (``path`` left out), an array as its dtype, shape and bytes, a NumPy
    scalar as the Python number (a motor file read back holds ``int`` where the simulator's
    spec holds ``int64``)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = [(f.name, getattr(value, f.name)) for f in dataclasses.fields(value)]
        return (type(value).__qualname__, *((k, _canonical(v)) for k, v in fields if k != "path"))
    if isinstance(value, np.ndarray):
        return ("ndarray", value.dtype.str, value.shape, np.ascontiguousarray(value).tobytes())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        return (type(value).__name__, *(_canonical(v) for v in value))
    if isinstance(value, dict):
        return ("dict", *sorted((k, _canonical(v)) for k, v in value.items()))
    return value


def _feed(digest: Any, value: Any) -> None:
    """Feed the canonical ``value`` to ``digest`` by value alone (a pickle would also encode
    which of its parts are one object, so equal arguments could differ)."""
    if isinstance(value, tuple):
        digest.update(b"(%d" % len(value))
        for part in value:
            _feed(digest, part)
        digest.update(b")")
    elif isinstance(value, bytes):
        digest.update(b"b%d:" % len(value) + value)
    else:
        text = repr(value).encode()  # str, int, float (repr round-trips), bool, None
        digest.update(b"r%d:" % len(text) + text)


def _key(signature: inspect.Signature, args: tuple[Any, ...], kwargs: dict[str, Any]) -> str:
    bound = signature.bind(*args, **kwargs)
    bound.apply_defaults()
    digest = hashlib.sha256()
    for name in sorted(bound.arguments):
        if name != "path":
            _feed(digest, (name, _canonical(bound.arguments[name])))
    return digest.hexdigest()


def _log(line: str) -> None:
    where = os.environ.get("REUSE_LOG")
    if where:
        test = os.environ.get("PYTEST_CURRENT_TEST", "?")
        with open(where, "a", encoding="utf-8") as out:
            out.write(f"{line} {test}\n")


def memoised(function: Callable[..., Any], kept: dict[str, Any]) -> Callable[..., Any]:
    """``function`` computed once per key (module docstring) into ``kept``."""
    signature = inspect.signature(function)
    name = function.__name__

    @functools.wraps(function)
    def once(*args: Any, **kwargs: Any) -> Any:
        key = name + _key(signature, args, kwargs)
        if key in kept:
            _log(f"hit {name}")
            return copy.deepcopy(kept[key])
        _log(f"miss {name}")
        result = function(*args, **kwargs)
        kept[key] = copy.deepcopy(result)
        return result

    once._memoised = True  # type: ignore[attr-defined]
    return once


#: The builds kept for the whole test process (module docstring): ``REUSE_BUILDS = "session"``
#: and the demo fixture.
SESSION: dict[str, Any] = {}


def _real(function: Any) -> Any:
    """``function`` less any memo around it (a memo inside another module's memo)."""
    while getattr(function, "_memoised", False):
        function = function.__wrapped__
    return function


@contextlib.contextmanager
def reused(kept: dict[str, Any], *modules: Any) -> Iterator[None]:
    """While open, ``build_tables`` and ``transfer_characterisation`` are computed once per key
    into ``kept``: in their own modules (which the CLI imports them from when it runs) and in
    ``modules`` (a test module binds them when imported)."""
    from torquemap.linearize import tables, transfer

    build = memoised(_real(tables.build_tables), kept)
    move = memoised(_real(transfer.transfer_characterisation), kept)
    with pytest.MonkeyPatch.context() as patch:
        for module in (tables, transfer, *modules):
            if _real(getattr(module, "build_tables", None)) is build.__wrapped__:
                patch.setattr(module, "build_tables", build)
            if _real(getattr(module, "transfer_characterisation", None)) is move.__wrapped__:
                patch.setattr(module, "transfer_characterisation", move)
        yield


@pytest.fixture(scope="module", autouse=True)
def _reused_builds(request: pytest.FixtureRequest) -> Iterator[None]:
    """In a module with ``REUSE_BUILDS = True``: its table builds and transfers, computed once
    (this module's docstring); with ``REUSE_BUILDS = "session"`` once for the test process;
    elsewhere nothing."""
    mode = getattr(request.module, "REUSE_BUILDS", False)
    if not mode:
        yield
        return
    with reused(SESSION if mode == "session" else {}, request.module):
        yield

"""Checks of the API reference: every public name documented, every cross-reference resolvable.

``make docs`` builds the reference with pdoc from the docstrings; pdoc leaves a reference it
cannot resolve as plain text, so this module finds those (and public names without a
docstring) first. ``python -m torquemap._apidoc`` prints them and exits with status 1 when there
are any; the test suite runs the same check.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
import types
from typing import Any

#: Modules left out of the reference: the command line (documented by ``--help``).
EXCLUDED = ("torquemap.cli", "torquemap.__main__")

_ROLE = re.compile(r":(?:func|class|mod|meth|attr|data|obj|exc):`~?([A-Za-z_][\w.]*)`")


def public_modules() -> list[str]:
    """Names of the modules the reference covers."""
    import torquemap

    names = ["torquemap"]
    for info in pkgutil.walk_packages(torquemap.__path__, prefix="torquemap."):
        name = info.name
        if any(name == e or name.startswith(e + ".") for e in EXCLUDED):
            continue
        if any(part.startswith("_") for part in name.split(".")):
            continue
        names.append(name)
    return sorted(names)


def _public_members(module: types.ModuleType) -> list[tuple[str, Any]]:
    names = getattr(module, "__all__", None)
    out = []
    for name, obj in vars(module).items():
        if name.startswith("_") or (names is not None and name not in names):
            continue
        if not (inspect.isfunction(obj) or inspect.isclass(obj)):
            continue
        if getattr(obj, "__module__", None) != module.__name__:
            continue  # imported from elsewhere: documented there
        out.append((name, obj))
    return out


def _resolve(target: str, module: types.ModuleType, owner: Any = None) -> bool:
    candidates = [target]
    if "." not in target or not target.startswith("torquemap"):
        candidates.append(f"{module.__name__}.{target}")
        if owner is not None:
            candidates.append(f"{module.__name__}.{owner.__name__}.{target}")
        candidates.append(f"torquemap.{target}")
    for cand in candidates:
        parts = cand.split(".")
        for cut in range(len(parts), 0, -1):
            try:
                obj: Any = importlib.import_module(".".join(parts[:cut]))
            except ImportError:
                continue
            ok = True
            for attr in parts[cut:]:
                if not hasattr(obj, attr):
                    # dataclass fields with slots are descriptors on the class; fine
                    ok = False
                    break
                obj = getattr(obj, attr)
            if ok:
                return True
            break
    # builtin and third-party names (ValueError, numpy.ndarray, matplotlib.figure.Figure, ...)
    import builtins

    if hasattr(builtins, target):
        return True
    root = target.split(".")[0]
    if root in ("numpy", "scipy", "matplotlib", "pyarrow", "os", "pathlib"):
        return True
    return False


def problems() -> list[str]:
    """Every public function or class without a docstring and every unresolvable reference."""
    out: list[str] = []
    for name in public_modules():
        module = importlib.import_module(name)
        docs: list[tuple[str, str, Any]] = [(name, module.__doc__ or "", None)]
        if not (module.__doc__ or "").strip():
            out.append(f"{name}: module has no docstring")
        for member, obj in _public_members(module):
            where = f"{name}.{member}"
            if not (obj.__doc__ or "").strip():
                out.append(f"{where}: no docstring")
            docs.append((where, obj.__doc__ or "", obj if inspect.isclass(obj) else None))
            if inspect.isclass(obj):
                for mname, meth in vars(obj).items():
                    if mname.startswith("_") or not callable(meth):
                        continue
                    if not (getattr(meth, "__doc__", None) or "").strip():
                        out.append(f"{where}.{mname}: no docstring")
                    docs.append((f"{where}.{mname}", getattr(meth, "__doc__", "") or "", obj))
        for where, doc, owner in docs:
            for target in _ROLE.findall(doc):
                if not _resolve(target, module, owner):
                    out.append(f"{where}: broken reference {target!r}")
    return out


def build(out_dir: str, modules: list[str] | None = None) -> list[str]:
    """Write the HTML reference of :func:`public_modules` into ``out_dir`` with pdoc.

    Parameters
    ----------
    out_dir
        Output folder (created).
    modules
        Module names to document instead of every public module.

    Returns
    -------
    list of str
        pdoc's warnings (for example a module it could not import), one per line.
    """
    import warnings
    from pathlib import Path

    import pdoc
    import pdoc.render

    pdoc.render.configure(docformat="numpy", show_source=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the root's __all__ lists its functions, so every direct child is named; pdoc adds a
        # subpackage's own modules itself
        import torquemap

        exported = {
            n for n in torquemap.__all__ if isinstance(getattr(torquemap, n), types.ModuleType)
        }
        top = [
            m
            for m in public_modules()
            if m.count(".") <= 1 and m.rsplit(".", 1)[-1] not in exported
        ]
        pdoc.pdoc(*(top if modules is None else modules), output_directory=Path(out_dir))
    return [str(w.message) for w in caught]


def main(argv: list[str] | None = None) -> int:
    """Print the problems (and with ``--build DIR`` write the reference); status 1 on any."""
    args = sys.argv[1:] if argv is None else argv
    found = problems()
    if len(args) == 2 and args[0] == "--build":
        found += [f"pdoc: {w}" for w in build(args[1])]
        if not found:
            print(f"wrote the API reference to {args[1]}/index.html")
    for line in found:
        print(line)
    print(f"{len(found)} problem(s) in the API reference", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""User text made safe for generated C source and for file names.

Names from the user's files (a motor name, a joint name) end up in C headers and in file names.
They are never pasted raw: identifiers are mapped onto ``[A-Za-z_][A-Za-z0-9_]*``, comment text
can never close (or open) a comment, and file-name parts hold only ``[A-Za-z0-9_.-]``.
"""

from __future__ import annotations

import math
import re

from torquemap.errors import InputError

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def c_identifier(text: str, *, fallback: str = "table") -> str:
    """A C identifier made from ``text``: other characters become ``_``, lower case.

    Leading and trailing underscores are dropped (names starting with ``_`` are reserved in C);
    a leading digit gets an ``m_`` prefix; text with no letter or digit gives ``fallback``.

    Examples
    --------
    >>> c_identifier("VR motor #2"), c_identifier("3phase"), c_identifier("*/ x; /*")
    ('vr_motor_2', 'm_3phase', 'x')
    >>> c_identifier("é")
    'table'
    """
    name = re.sub(r"_+", "_", re.sub(r"[^0-9A-Za-z_]", "_", text)).strip("_").lower()
    if not name:
        name = fallback
    if name[0].isdigit():
        name = f"m_{name}"
    check_c_identifier(name)
    return name


def check_c_identifier(name: str) -> str:
    """``name`` unchanged if it is a C identifier ``[A-Za-z_][A-Za-z0-9_]*``; InputError if not.

    Examples
    --------
    >>> check_c_identifier("phase_1")
    'phase_1'
    """
    if not _IDENTIFIER.fullmatch(name):
        raise InputError(f"{name!r} is not a C identifier ([A-Za-z_][A-Za-z0-9_]*)")
    return name


def c_comment(text: str) -> str:
    """``text`` safe inside a C block comment: printable ASCII, no ``*/``, ``/*`` or ``??``.

    Other characters are written as Python-style escapes (``\\n``, ``\\xe9``); ``*/`` becomes
    ``* /`` and ``/*`` becomes ``/ *``, so user text never closes the comment (and gcc's
    ``-Wcomment`` stays quiet); ``??`` becomes ``? ?`` (no trigraphs).

    Examples
    --------
    >>> c_comment("*/ int injected = 42; /*")
    '* / int injected = 42; / *'
    >>> c_comment("line\\nbreak é")
    'line\\\\nbreak \\\\xe9'
    """
    out = "".join(
        ch if " " <= ch <= "~" else ch.encode("unicode_escape").decode("ascii") for ch in text
    )
    while "*/" in out or "/*" in out or "??" in out:
        out = out.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
    return out


def c_float(value: float, *, suffix: str = "") -> str:
    """A C floating literal for a finite ``value`` (always with a ``.`` or an exponent).

    Examples
    --------
    >>> c_float(1.0, suffix="f"), c_float(0.000125), c_float(3e20)
    ('1.0f', '0.000125', '3e+20')
    """
    v = float(value)
    if not math.isfinite(v):
        raise InputError(f"cannot write {v} as a C number")
    text = repr(v)
    if not any(c in text for c in ".e"):
        text += ".0"
    return text + suffix


def file_stem(text: str, *, fallback: str = "x") -> str:
    """A file-name part from ``text``: only ``[A-Za-z0-9_.-]``, no leading dot, not empty.

    Examples
    --------
    >>> file_stem("../../etc/passwd"), file_stem("joint a"), file_stem("")
    ('etc_passwd', 'joint_a', 'x')
    """
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", text)
    name = re.sub(r"\.{2,}", "_", name)
    name = re.sub(r"_+", "_", name).strip("._-")
    return name[:100] or fallback

"""The API reference: every public name documented, every cross-reference resolvable."""

from __future__ import annotations

from pathlib import Path

from torquemap import _apidoc


def test_no_undocumented_name_and_no_broken_reference() -> None:
    assert _apidoc.problems() == []


def test_the_check_can_fail() -> None:
    # a broken reference and a missing docstring are found
    import torquemap.api as api

    def undocumented() -> None:
        pass

    undocumented.__module__ = "torquemap.api"
    api.undocumented = undocumented  # type: ignore[attr-defined]
    old = api.estimate.__doc__
    try:
        api.estimate.__doc__ = (old or "") + "\nSee :func:`torquemap.nowhere.nothing`."
        found = _apidoc.problems()
    finally:
        del api.undocumented  # type: ignore[attr-defined]
        api.estimate.__doc__ = old
    assert "torquemap.api.undocumented: no docstring" in found
    assert "torquemap.api.estimate: broken reference 'torquemap.nowhere.nothing'" in found


def test_pdoc_links_the_top_level_api(tmp_path: Path) -> None:
    assert _apidoc.build(str(tmp_path), ["torquemap.api", "torquemap.io"]) == []
    page = (tmp_path / "torquemap" / "api.html").read_text(encoding="utf-8")
    # numpydoc sections rendered, cross-references turned into links
    assert "Parameters" in page and 'href="io.html#Log"' in page

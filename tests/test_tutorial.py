"""docs/tutorial.md (and estimation.md) cannot drift: their commands print what they show.

The expensive commands run once per session in shared fixtures (conftest.py), with the same
command lines the tutorial gives: the demo, ``simulate scara``, ``identify`` and the VR rig; the
other tests use what they wrote. Everything else runs here. Regenerate the outputs with
``PYTHONPATH=src python docs/gen_tutorial.py`` after changing what a command prints.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import IDENTIFY, RIG_VR, SIMULATE_SCARA, DemoRun, Ran

from torquemap.io import read_table

# one worker runs the demo for both files (conftest.py)
pytestmark = pytest.mark.xdist_group("demo")

#: tests/_reuse.py: ``linearize build rig/motor.toml rig/data.csv`` reads the tables the demo
#: built from the same rows with the same options (the demo fixture keeps them for the session)
REUSE_BUILDS = "session"

DOCS = Path(__file__).parents[1] / "docs"


def _link(source: Path, target: Path) -> None:
    """``target`` as ``source`` (a file or a folder of files), by links: nothing is copied."""
    if source.is_dir():
        target.mkdir()
        for path in source.iterdir():
            (target / path.name).symlink_to(path)
    else:
        target.symlink_to(source)


@pytest.mark.parametrize("page", ["tutorial.md", "estimation.md"])
def test_the_docs_print_what_they_show(
    page: str,
    tutorial: Any,
    scara_run: Ran,
    scara_identified: Ran,
    vr_rig: Ran,
    demo_run: DemoRun,
    tmp_path: Path,
) -> None:
    # command -> (what it wrote, what it printed) for the commands the session already ran
    shared = {
        SIMULATE_SCARA: (scara_run.folder / "bench", scara_run.printed[SIMULATE_SCARA]),
        IDENTIFY: (scara_identified.folder / "bench" / "model.toml", None),
        RIG_VR: (vr_rig.folder / "rig", vr_rig.printed[RIG_VR]),
        "torquemap demo --out demo-out": (None, demo_run.out),
    }

    def runner(command: str) -> str:
        if command not in shared:
            return str(tutorial.run(command))
        source, printed = shared[command]
        if source is not None:
            _link(source, Path(command.split()[-1]))
        return printed if printed is not None else scara_identified.printed[command]

    assert [p.name for p in tutorial.PAGES] == ["tutorial.md", "estimation.md"]
    text = (DOCS / page).read_text(encoding="utf-8")
    blocks = tutorial.parse(text)
    assert sum(b.output is not None for b in blocks) >= (10 if page == "tutorial.md" else 1)
    assert all(b.commands for b in blocks)
    with tutorial.working_directory(tmp_path):
        printed = tutorial.run_all(blocks, runner)
    for block, got in zip(blocks, printed, strict=True):
        if block.output is None:
            continue
        # each block as a whole, so that a failure names its commands; numbers within 0.2 %
        # (another CPU's rounding, 0.04 % seen between an AMD and an Intel machine), words exactly
        bad = tutorial.mismatches(got, block.output, rtol=2e-3)
        assert not bad, (
            f"docs/{page} shows other output for:\n  "
            + "\n  ".join(block.commands)
            + "\n"
            + "\n".join(bad[:20])
            + "\n(regenerate: PYTHONPATH=src python docs/gen_tutorial.py)"
        )


def test_make_demo_is_the_demo_command() -> None:
    makefile = (DOCS.parent / "Makefile").read_text(encoding="utf-8")
    assert "OUT ?= demo-out" in makefile
    assert re.search(r"^demo:.*\n\t\$\(BIN\)/torquemap demo --out \$\(OUT\)$", makefile, re.M)


def test_masks_hide_only_the_seconds(tutorial: Any) -> None:
    assert tutorial.masked("report: demo-out/report.html   (74 s)") == tutorial.masked(
        "report: demo-out/report.html   (181 s)"
    )
    assert tutorial.masked("wrote a (3 sections)") != tutorial.masked("wrote a (4 sections)")


def test_bench_files_are_as_formats_md_says(scara_bench: Path) -> None:
    text = (DOCS / "formats.md").read_text(encoding="utf-8")
    for name in ("sweep", "circle"):
        m = re.search(rf"`{name}\.csv` \| log.*?2 kHz, (\d+) s \(([\d ]+) rows\)", text)
        assert m, name
        t = read_table(scara_bench / f"{name}.csv")["t"]
        assert t.size == int(m.group(2).replace(" ", ""))
        assert round(float(t[-1])) == int(m.group(1))
        np.testing.assert_allclose(np.diff(t[:3]), 1 / 2000)

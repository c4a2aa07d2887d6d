"""Issue 15 item 2: user text never becomes code; every generated C header compiles.

Each header is compiled by gcc with ``-Wall -Werror -fsyntax-only`` (skipped only when gcc is
missing), together with a probe that must see exactly the symbols the header documents and
none that a hostile name tries to inject.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from torquemap.ctext import c_comment, c_identifier, file_stem
from torquemap.errors import InputError
from torquemap.linearize.export import c_header
from torquemap.linearize.motor import motor_spec
from torquemap.linearize.tables import TableSet, build_tables
from torquemap.model import JointModel, Model, PdtvLine
from torquemap.pdtv_map import pdtv_map, write_pdtv_map
from torquemap.robot import robot_from_dict

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc is not installed")

HOSTILE = (
    "*/ int injected_symbol = 42; /*",
    'x"; int injected_symbol = 1; //\n#define injected_symbol 1\n',
    "??/\n é \x00 \\",
    "_",
    "9lives",
)


def compile_c(tmp_path: Path, header: str, probe: str) -> subprocess.CompletedProcess[str]:
    (tmp_path / "gen.h").write_text(header)
    (tmp_path / "probe.c").write_text(f'#include "gen.h"\n{probe}\n')
    assert GCC is not None
    return subprocess.run(
        [GCC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-fsyntax-only", "probe.c"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )


def make_tables(name: str, *, bits: int | None, scaling: str) -> TableSet:
    spec = motor_spec(name, phases=3, positions_per_cycle=12, equilibrium_positions=(2, 6, 10))
    p, w = np.meshgrid(np.arange(12), np.arange(0, 256, 15), indexing="ij")
    t = (2 + np.cos(6 * np.pi * p / 12)) * (w / 255.0) ** 2
    return build_tables(
        spec,
        p.ravel(),
        w.ravel(),
        t.ravel(),
        actuation_bits=bits,
        command_scaling=scaling,  # type: ignore[arg-type]
    )


@needs_gcc
@pytest.mark.parametrize("bits", [None, 1, 9, 16, 17, 32])
@pytest.mark.parametrize("scaling", ["linear", "log"])
def test_table_headers_compile_for_every_width(
    bits: int | None, scaling: str, tmp_path: Path
) -> None:
    tables = make_tables("VR motor 1", bits=bits, scaling=scaling)
    text = c_header(tables)
    probe = (
        "unsigned long long probe(void) { return (unsigned long long)vr_motor_1_phase_3[11][255]"
        " + VR_MOTOR_1_PHASES + VR_MOTOR_1_POSITIONS + VR_MOTOR_1_ACTUATION_MAX"
        " + (unsigned long long)(VR_MOTOR_1_TORQUE_PER_COUNT + VR_MOTOR_1_TORQUE_MAX); }"
    )
    done = compile_c(tmp_path, text, probe)
    assert done.returncode == 0, done.stderr
    ctype = {None: "uint8_t", 1: "uint8_t", 8: "uint8_t", 9: "uint16_t", 16: "uint16_t"}.get(
        bits, "uint32_t"
    )
    assert f"static const {ctype} vr_motor_1_phase_1[12][256]" in text


@needs_gcc
@pytest.mark.parametrize("name", HOSTILE)
def test_a_hostile_motor_name_stays_in_its_comment(name: str, tmp_path: Path) -> None:
    text = c_header(make_tables(name, bits=None, scaling="linear"))
    ident = c_identifier(name, fallback="motor")
    probe = f"int probe(void) {{ return {ident}_phase_1[0][0] + {ident.upper()}_PHASES; }}"
    assert compile_c(tmp_path, text, probe).returncode == 0
    # the injected symbol is not declared: using it fails to compile
    bad = compile_c(tmp_path, text, "int probe(void) { return injected_symbol; }")
    assert bad.returncode != 0 and "injected_symbol" in bad.stderr


def test_prefix_must_be_an_identifier() -> None:
    tables = make_tables("m", bits=None, scaling="linear")
    assert "static const uint8_t fw_tbl_phase_1" in c_header(tables, prefix="fw_tbl")
    for prefix in ("1x", "a-b", "x; int y", "é"):
        with pytest.raises(InputError, match="not a C identifier"):
            c_header(tables, prefix=prefix)


def pdtv_model(joint: str, lines: tuple[PdtvLine, ...]) -> Model:
    robot = robot_from_dict(
        {
            "robot": {"kinematics": "none"},
            "joints": {joint: {"gear_ratio": 1, "torque_constant": 0.5}},
        }
    )
    return Model(robot=robot, joints={joint: JointModel(pdtv=lines)})


@needs_gcc
@pytest.mark.parametrize("int_type", ["int16", "int8"])
@pytest.mark.parametrize("joint", ["a", *HOSTILE[:3]])
@pytest.mark.parametrize("with_lines", [True, False])
def test_pdtv_headers_compile(int_type: str, joint: str, with_lines: bool, tmp_path: Path) -> None:
    lines = (PdtvLine(order=2, amplitude=0.01, phase=0.3),) if with_lines else ()
    table = pdtv_map(pdtv_model(joint, lines), joint, bins=37)
    write_pdtv_map(tmp_path / "m.h", table, file_format="c-header", int_type=int_type)  # type: ignore[arg-type]
    text = (tmp_path / "m.h").read_text()
    ident = c_identifier(joint, fallback="joint")
    probe = (
        f"float probe(void) {{ return pdtv_{ident}[PDTV_{ident.upper()}_BINS - 1]"
        f" * PDTV_{ident.upper()}_SCALE_A; }}"
    )
    done = compile_c(tmp_path, text, probe)
    assert done.returncode == 0, done.stderr + text[:600]
    if not with_lines:  # the "#define ..._SCALE_A 1f": now a valid float literal
        assert f"PDTV_{ident.upper()}_SCALE_A 1.0f " in text


def test_text_helpers() -> None:
    assert "*/" not in c_comment("a */ b /* c ** / d */") and "/*" not in c_comment("/*/*")
    assert c_comment("é\n") == "\\xe9\\n"
    for text in HOSTILE:
        ident = c_identifier(text)
        assert ident.isascii() and (ident[0].isalpha() or ident[0] == "_")
        assert all(c.isalnum() or c == "_" for c in ident)
        stem = file_stem(text)
        assert "/" not in stem and not stem.startswith(".") and stem
    assert file_stem("../../etc/passwd") == "etc_passwd"

"""Silent-harm audit through the CLI: random SCARA robots as a user would run them.

One command: ``python benchmarks/cli_audit.py --first 200 --robots 40 [--work DIR]``.

Per robot ``seed`` (:func:`torquemap.sim.scara_family.random_bench`): ``torquemap simulate scara
--random SEED``, ``identify`` on the sweep log, ``estimate`` on the circle log, ``report`` on both,
each as its own process, the way the tutorial runs them. The forces the CLI wrote are scored
against the simulator's truth (``truth.csv``) with ``benchmarks/force_accuracy.py``'s scoring and
its oracle (the true model through the same ``model`` pipeline). Per robot: RMS force error in %
of the spring force over the answered samples, the ratio to the oracle, the share of force
errors within 2 sigma, the flagged share and every warning any command printed. A robot's answer
is bad when the ratio exceeds 3, the error exceeds 15 % of the spring or fewer than 80 % of the
errors lie within 2 sigma; the last column says whether a warning told the user.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from force_accuracy import _score, oracle_models, score_columns

from torquemap.estimate import estimate_forces
from torquemap.io import read_log, read_table
from torquemap.model import load_model
from torquemap.sim.scara_family import random_bench

#: A robot's answer is bad above these (the brief of stop 35).
BAD_RATIO, BAD_PERCENT, BAD_WITHIN = 3.0, 15.0, 0.80


def run(args: list[str]) -> tuple[int, list[str]]:
    """Run ``torquemap ARGS -q``; return its exit code and its warning and error lines."""
    exe = Path(sys.executable).with_name("torquemap")
    proc = subprocess.run([str(exe), *args, "-q"], capture_output=True, text=True)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    return proc.returncode, lines


def score_forces(
    forces: Path, truth_csv: Path, spring: float, oracle: dict[str, Any] | None
) -> dict[str, Any]:
    """Score the CLI's forces table against the truth table and the oracle's errors."""
    truth = read_table(truth_csv)
    true_force = np.c_[truth["fx"], truth["fy"]]
    table = read_table(forces)
    s = score_columns({k: np.asarray(table[k]) for k in table}, true_force, spring)
    s["ratio"] = math.nan
    if oracle is not None and oracle["ok"].shape == s["ok"].shape:
        both = s["ok"] & oracle["ok"]
        if both.any():
            num = np.mean(np.sum(s["err"][both] ** 2, axis=1))
            den = np.mean(np.sum(oracle["err"][both] ** 2, axis=1))
            s["ratio"] = math.sqrt(float(num / den)) if den > 0 else math.nan
    return s


def oracle_score(
    d: Path, seed: int, cutoff: float, circle_csv: Path, truth_csv: Path
) -> dict[str, Any]:
    """The oracle's score on a circle log (the better of its variants, as the benchmark)."""
    truth = load_model(d / "truth.toml")
    circle = read_log(circle_csv, truth.robot)
    table = read_table(truth_csv)
    true_force = np.c_[table["fx"], table["fy"]]
    spring = random_bench(seed).circle.spring_force
    best: dict[str, Any] | None = None
    for model in oracle_models(random_bench(seed), truth, circle.t).values():
        est = estimate_forces(model, circle, method="model", cutoff=cutoff)
        s = _score(est, true_force, spring)
        if best is None or s["rms"] < best["rms"]:
            best = s
    assert best is not None
    return best


def scored_estimate(
    seed: int,
    d: Path,
    model: Path,
    circle_csv: Path,
    truth_csv: Path,
    tag: str,
    cutoff: float,
    extra: tuple[str, ...] = (),
) -> dict[str, Any]:
    """``torquemap estimate MODEL CIRCLE`` scored against ``truth_csv`` and the oracle."""
    out_csv = d / f"forces_{tag}.csv"
    code, lines = run(["estimate", str(model), str(circle_csv), "-o", str(out_csv), *extra])
    out: dict[str, Any] = {"seed": seed, "tag": tag, "code": code, "warnings": lines}
    if code != 0:
        out["wrote_output"] = out_csv.exists()
        return out
    out.update(_scores(seed, d, out_csv, circle_csv, truth_csv, cutoff))
    return out


def _scores(
    seed: int, d: Path, forces_csv: Path, circle_csv: Path, truth_csv: Path, cutoff: float
) -> dict[str, float]:
    """The forces in ``forces_csv`` scored against ``truth_csv`` and the oracle on the circle."""
    oracle = oracle_score(d, seed, cutoff, circle_csv, truth_csv)
    s = score_forces(forces_csv, truth_csv, random_bench(seed).circle.spring_force, oracle)
    keys = ("rms", "ratio", "within", "flagged")
    return {**{k: s[k] for k in keys}, "oracle_rms": oracle["rms"]}


def _write_rows(src: Path, dst: Path, rows: np.ndarray, t_offset: float = 0.0) -> None:
    table = read_table(src)
    cols = {k: np.asarray(v)[rows] for k, v in table.items()}
    cols["t"] = cols["t"] + t_offset
    names = list(cols)
    data = np.column_stack([cols[k] for k in names])
    np.savetxt(dst, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def variations(seed: int, work: Path, cutoff: float) -> list[dict[str, Any]]:
    """What a user would do differently on robot ``seed`` (audited first, so its files exist)."""
    d = work / f"r{seed}"
    circle, truth, model = d / "circle.csv", d / "truth.csv", d / "model.toml"
    results = []
    t = np.asarray(read_table(circle)["t"])
    n = t.size
    every = max(1, round(1.0 / (250.0 * float(np.median(np.diff(t))))))
    cases: dict[str, np.ndarray] = {
        "250Hz": np.arange(0, n, every),
        "short25": np.arange(0, n // 4),
        "short1s": np.flatnonzero(t - t[0] <= 1.0),
    }
    for tag, rows in cases.items():
        _write_rows(circle, d / f"circle_{tag}.csv", rows)
        _write_rows(truth, d / f"truth_{tag}.csv", rows)
        results.append(
            scored_estimate(
                seed, d, model, d / f"circle_{tag}.csv", d / f"truth_{tag}.csv", tag, cutoff
            )
        )
    all_rows = np.arange(n)
    _write_rows(circle, d / "circle_t17.csv", all_rows, t_offset=1.7e9)
    _write_rows(truth, d / "truth_t17.csv", all_rows, t_offset=1.7e9)
    results.append(
        scored_estimate(
            seed, d, model, d / "circle_t17.csv", d / "truth_t17.csv", "t+1.7e9", cutoff
        )
    )
    for w in ("0.02", "0.1"):
        results.append(
            scored_estimate(
                seed, d, model, circle, truth, f"est-window{w}", cutoff, ("--window", w)
            )
        )
    mw = d / "model_w0.1.toml"
    code, lines = run(
        ["identify", str(d / "robot.toml"), str(d / "sweep.csv"), "-o", str(mw), "--window", "0.1"]
    )
    if code == 0:
        results.append(scored_estimate(seed, d, mw, circle, truth, "id-window0.1", cutoff))
        results[-1]["identify_warnings"] = lines
    else:
        results.append({"seed": seed, "tag": "id-window0.1", "code": code, "warnings": lines})
    other = work / f"r{seed + 1}" / "model.toml"
    if other.exists():
        results.append(
            scored_estimate(seed, d, other, circle, truth, f"model-of-{seed + 1}", cutoff)
        )
    return results


def audit_robot(seed: int, work: Path, cutoff: float, report: bool) -> dict[str, Any]:
    d = work / f"r{seed}"
    warnings: dict[str, list[str]] = {}
    codes: dict[str, int] = {}
    if not (d / "truth.csv").exists():
        codes["simulate"], warnings["simulate"] = run(
            ["simulate", "scara", "--random", str(seed), "--out", str(d)]
        )
    codes["identify"], warnings["identify"] = run(
        ["identify", str(d / "robot.toml"), str(d / "sweep.csv"), "-o", str(d / "model.toml")]
    )
    out: dict[str, Any] = {"seed": seed, "codes": codes, "warnings": warnings}
    if codes["identify"] != 0:
        return out
    codes["estimate"], warnings["estimate"] = run(
        ["estimate", str(d / "model.toml"), str(d / "circle.csv"), "-o", str(d / "forces.csv")]
    )
    if report:
        codes["report"], warnings["report"] = run(
            [
                "report",
                str(d / "model.toml"),
                str(d / "sweep.csv"),
                str(d / "circle.csv"),
                "-o",
                str(d / "report.html"),
            ]
        )
    if codes["estimate"] != 0:
        return out
    circle, truth = d / "circle.csv", d / "truth.csv"
    out.update(_scores(seed, d, d / "forces.csv", circle, truth, cutoff))
    return out


def is_bad(r: dict[str, Any]) -> bool:
    if "rms" not in r:
        return False
    return bool(
        r["ratio"] > BAD_RATIO
        or r["rms"] > BAD_PERCENT
        or (math.isfinite(r["within"]) and r["within"] < BAD_WITHIN)
    )


#: Warning kinds, by a phrase each holds (the audit table's columns).
KINDS = {
    "slow": "below the slowest steady sweep pass",
    "gap": "between steady sweep passes",
    "implausible": "implausible torque samples",
    "elbow": "cos_elbow set to 0",
    "dissipative": "not dissipative",
    "motion": "in motion",
}


def kinds(r: dict[str, Any]) -> list[str]:
    """The kinds of warning ``identify`` and ``estimate`` printed for a robot (the report
    repeats them)."""
    lines = [ln for cmd in ("identify", "estimate") for ln in r["warnings"].get(cmd, [])]
    # a rest-sigma warning tried at stop 35 and not kept printed on a few held-out robots
    # audited while it was in the code
    lines = [ln for ln in lines if "are bridged (at rest" not in ln]
    found = [k for k, phrase in KINDS.items() if any(phrase in ln for ln in lines)]
    other = [ln for ln in lines if not any(p in ln for p in KINDS.values())]
    return found + (["other"] if other else [])


def audit_table(paths: list[Path]) -> str:
    """The audit table (markdown) of JSON lines written by ``--json``."""
    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines()]
    rows = sorted({r["seed"]: r for r in rows}.values(), key=lambda r: r["seed"])
    out = [
        "| robot | RMS % of spring | / oracle | within 2 sigma | flagged | bad | warnings |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "rms" not in r:
            out.append(f"| {r['seed']} | refused: {r['codes']} | | | | | |")
            continue
        out.append(
            f"| {r['seed']} | {r['rms']:.2f} | {r['ratio']:.2f} | {r['within']:.1%} | "
            f"{r['flagged']:.1%} | {'**bad**' if is_bad(r) else ''} | "
            f"{', '.join(kinds(r)) or 'none'} |"
        )
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--first", type=int, default=200)
    parser.add_argument("--robots", type=int, default=40)
    parser.add_argument("--work", type=Path, default=Path("/tmp/cli_audit"))
    parser.add_argument("--cutoff", type=float, default=2.0)
    parser.add_argument("--no-report", action="store_true", help="skip torquemap report")
    parser.add_argument("--variations", type=str, default="", help="seeds, comma separated")
    parser.add_argument("--table", type=Path, nargs="*", help="print the table of JSON files")
    parser.add_argument("--json", type=Path, default=None, help="append results as JSON lines")
    args = parser.parse_args()
    if args.table:
        print(audit_table(args.table))
        return
    args.work.mkdir(parents=True, exist_ok=True)
    if args.variations:
        for seed in (int(x) for x in args.variations.split(",")):
            for r in variations(seed, args.work, args.cutoff):
                if args.json is not None:
                    with args.json.open("a") as fh:
                        fh.write(json.dumps(r) + "\n")
                print(
                    f"{seed:>4} {r['tag']:<14} exit {r['code']} rms {r.get('rms', math.nan):6.2f} % "
                    f"ratio {r.get('ratio', math.nan):5.2f} 2sig {r.get('within', math.nan):6.1%} "
                    f"flag {r.get('flagged', math.nan):6.1%} {'BAD' if is_bad(r) else ''}",
                    flush=True,
                )
                for line in r["warnings"] + r.get("identify_warnings", []):
                    print(f"       {line}", flush=True)
        return
    for seed in range(args.first, args.first + args.robots):
        r = audit_robot(seed, args.work, args.cutoff, not args.no_report)
        if args.json is not None:
            with args.json.open("a") as fh:
                fh.write(json.dumps(r) + "\n")
        n_warn = sum(len(v) for v in r["warnings"].values())
        print(
            f"{seed:>4} rms {r.get('rms', math.nan):6.2f} % ratio {r.get('ratio', math.nan):5.2f} "
            f"2sig {r.get('within', math.nan):6.1%} flag {r.get('flagged', math.nan):6.1%} "
            f"warnings {n_warn} {'BAD' if is_bad(r) else ''} codes {r['codes']}",
            flush=True,
        )
        for cmd, lines in r["warnings"].items():
            for line in lines:
                print(f"     {cmd}: {line}", flush=True)


if __name__ == "__main__":
    main()

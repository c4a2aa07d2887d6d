"""Where the whole-log model's force error over the oracle's comes from (issue 12).

One command: ``python benchmarks/force_decomposition.py [--first 1] [--robots 20] [--jobs 2]``.

For each random robot of :func:`torquemap.sim.scara_family.random_bench` (as
``benchmarks/force_accuracy.py`` draws them) this simulates the sweep and the circle,
identifies the whole-log model (``identify --friction whole``) and the pass model (``--friction
passes``, only for its answered samples: the "steady" part), builds the oracle as
``force_accuracy.oracle_models`` does (the better of its static and, for LuGre robots, dynamic
variants), then scores hybrids on the circle with the ``model`` method:

* ``ident+T:<c>``: the identified model with ONE component replaced by the truth's;
* ``oracle+I:<c>``: the oracle with ONE component replaced by the identified one;

components ``friction`` (the law), ``pdtv`` (the lines), ``inertia`` and ``delay`` (the torque
channel's delay, which the model keeps in its notes). A hybrid keeps its base model's other
notes (the identified model's for ``ident+T``, the oracle's for ``oracle+I``).

Per hybrid and robot: the ratio of its RMS force error to the oracle's over the samples both
answer, over the whole circle, the "steady" samples (the pass model answers them: every joint
at or above its slowest steady sweep pass, outside reversals) and the "below" rest. Read
``ident+T:c`` as "how much of the excess is left when c is right" and ``oracle+I:c`` as "how
much excess c alone brings". Identified models are cached (pickled) in ``--cache`` (default a
folder under the temporary directory), so a second run only estimates.

Only a benchmark reads the truth; the library never does.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import dataclasses
import math
import multiprocessing
import pickle
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from force_accuracy import _score, oracle_models, simulate_family_robot

from torquemap.estimate import estimate_forces
from torquemap.identify import identify_model
from torquemap.model import Model

COMPONENTS = ("friction", "bridge", "friction+bridge", "pdtv", "inertia", "delay")
HYBRIDS = (
    "whole",
    *(f"ident+T:{c}" for c in COMPONENTS),
    *(f"oracle+I:{c}" for c in COMPONENTS),
)
PARTS = ("all", "steady", "below")


def swap(base: Model, donor: Model, component: str) -> Model:
    """``base`` with ``component`` of every joint taken from ``donor``; every other part and
    note is ``base``'s. Components: ``friction`` (the law), ``bridge`` (the notes'
    ``friction_observed_speed``, below which ``estimate`` bridges over the law; absent = none),
    ``friction+bridge`` (both), ``pdtv``, ``inertia``, ``delay`` (the notes' ``channel_delay``)."""
    if "+" in component:
        for part in component.split("+"):
            base = swap(base, donor, part)
        return base
    note = {"delay": "channel_delay", "bridge": "friction_observed_speed"}.get(component)
    if note is not None:
        base_joints = dict(base.notes.get("joints", {}))
        donor_joints = donor.notes.get("joints", {})
        for name in base.joints:
            entry = dict(base_joints.get(name, {}))
            value = donor_joints.get(name, {}).get(note)
            if value is None:
                entry.pop(note, None)
            else:
                entry[note] = float(value)
            base_joints[name] = entry
        return dataclasses.replace(base, notes=dict(base.notes, joints=base_joints))
    joints = {
        name: dataclasses.replace(joint, **{component: getattr(donor.joints[name], component)})
        for name, joint in base.joints.items()
    }
    return dataclasses.replace(base, joints=joints)


def _identified(seed: int, robot: Any, sweep: Any, cache: Path) -> dict[str, Model]:
    path = cache / f"robot{seed}.pkl"
    if path.exists():
        with path.open("rb") as fh:
            return pickle.load(fh)  # type: ignore[no-any-return]
    out = {key: identify_model(robot, [sweep], friction=key).model for key in ("whole", "passes")}  # type: ignore[arg-type]
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    with tmp.open("wb") as fh:
        pickle.dump(out, fh)
    tmp.replace(path)
    return out


def _ratio(s: dict[str, Any], o: dict[str, Any], mask: np.ndarray) -> float:
    both = mask & s["ok"] & o["ok"]
    if both.sum() < 10:
        return math.nan
    den = float(np.mean(np.sum(o["err"][both] ** 2, axis=1)))
    num = float(np.mean(np.sum(s["err"][both] ** 2, axis=1)))
    return math.sqrt(num / den) if den > 0 else math.nan


def robot_ratios(seed: int, cache: Path, cutoff: float) -> dict[str, Any]:
    """Per hybrid and part, the ratio to the oracle on random robot ``seed``."""
    t0 = time.perf_counter()
    sim = simulate_family_robot(seed)
    bench, truth, sweep, circle = sim.bench, sim.truth, sim.sweep, sim.circle
    robot = truth.robot
    true_force, spring = sim.true_force, sim.spring
    models = _identified(seed, robot, sweep, cache)
    whole = models["whole"]

    def score(model: Model) -> dict[str, Any]:
        est = estimate_forces(model, circle, method="model", cutoff=cutoff)
        return _score(est, true_force, spring)

    oracle_runs = {key: (m, score(m)) for key, m in oracle_models(bench, truth, circle.t).items()}
    best = min(oracle_runs, key=lambda key: oracle_runs[key][1]["rms"])
    oracle, o = oracle_runs[best]
    steady = score(models["passes"])["ok"]
    built: dict[str, Model] = {"whole": whole}
    for c in COMPONENTS:
        built[f"ident+T:{c}"] = swap(whole, oracle, c)
        built[f"oracle+I:{c}"] = swap(oracle, whole, c)
    ratios: dict[str, dict[str, float]] = {}
    rms: dict[str, float] = {"oracle": o["rms"]}
    for name, model in built.items():
        s = score(model)
        rms[name] = s["rms"]
        ratios[name] = {
            part: _ratio(s, o, mask)
            for part, mask in (
                ("all", np.ones_like(steady)),
                ("steady", steady),
                ("below", ~steady),
            )
        }
    return {
        "seed": seed,
        "ratios": ratios,
        "rms": rms,
        "steady_share": float(steady.mean()),
        "oracle": best,
        "time": time.perf_counter() - t0,
    }


def _task(task: tuple[int, str, float]) -> dict[str, Any]:
    seed, cache, cutoff = task
    try:
        return robot_ratios(seed, Path(cache), cutoff)
    except Exception as exc:  # a benchmark reports, it does not stop
        return {"seed": seed, "error": f"{type(exc).__name__}: {exc}"}


def _short(hybrid: str) -> str:
    """A hybrid's column label in the per-robot tables."""
    for long, short in (("ident+", ""), ("oracle+", ""), ("friction", "fric"), ("bridge", "brdg")):
        hybrid = hybrid.replace(long, short)
    return hybrid


def tables(results: list[dict[str, Any]]) -> str:
    """Summary (median and worst per hybrid and part) and per-robot ratios, as text."""
    ok = sorted((r for r in results if "error" not in r), key=lambda r: r["seed"])
    lines = [
        f"Decomposition on {len(ok)} random robots (seeds {ok[0]['seed']}..{ok[-1]['seed']}): "
        "RMS force error ratio to the oracle over the samples both answer; ident+T:c = the "
        "identified (whole) model with c from the truth, oracle+I:c = the oracle with c "
        "identified; steady = the samples the pass model answers, below = the rest"
    ]
    head = f"{'hybrid':<24}" + "".join(f"{p + ' med':>12}{p + ' worst':>13}" for p in PARTS)
    lines += [head, "-" * len(head)]
    for h in HYBRIDS:
        cells = []
        for p in PARTS:
            x = np.array([r["ratios"][h][p] for r in ok], dtype=float)
            if not np.isfinite(x).any():
                cells.append(f"{'-':>12}{'-':>13}")
                continue
            w = int(np.nanargmax(x))
            cells.append(f"{np.nanmedian(x):>12.2f}{x[w]:>8.2f} ({ok[w]['seed']:>2})")
        lines.append(f"{h:<24}" + "".join(cells))
    lines.append("")
    for p in PARTS:
        lines.append(f"Per robot, part '{p}' (ratio to the oracle):")
        head = f"{'seed':>4}{'steady%':>8}" + "".join(f"{_short(h):>11}" for h in HYBRIDS)
        lines.append(
            "(T:c = identified model with the truth's c; I:c = oracle with the identified c)"
        )
        lines.append(head)
        for r in ok:
            lines.append(
                f"{r['seed']:>4}{r['steady_share']:>8.0%}"
                + "".join(f"{r['ratios'][h][p]:>11.2f}" for h in HYBRIDS)
            )
        lines.append("")
    for r in results:
        if "error" in r:
            lines.append(f"robot {r['seed']}: {r['error']}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--first", type=int, default=1, help="seed of the first random robot")
    parser.add_argument("--robots", type=int, default=20, help="random robots (default 20)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--cutoff", type=float, default=2.0, help="low-pass cut-off [Hz]")
    parser.add_argument(
        "--cache",
        default=str(Path(tempfile.gettempdir()) / "torquemap_decomposition"),
        help="folder of cached identified models (delete it after changing identify)",
    )
    args = parser.parse_args()
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    tasks = [(args.first + k, str(cache), args.cutoff) for k in range(args.robots)]
    t0 = time.perf_counter()
    results = []
    with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
        for r in pool.imap_unordered(_task, tasks):
            if "error" in r:
                print(f"robot {r['seed']:>3}: {r['error']}", flush=True)
            else:
                print(
                    f"robot {r['seed']:>3} ({r['time']:.0f} s): "
                    + ", ".join(f"{h} {r['ratios'][h]['all']:.2f}" for h in HYBRIDS),
                    flush=True,
                )
            results.append(r)
    print()
    print(tables(results))
    print(f"\nwall time {time.perf_counter() - t0:.0f} s on {args.jobs} processes")


if __name__ == "__main__":
    main()

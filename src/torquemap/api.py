"""The public Python API: the functions ``torquemap`` exports at the top level.

Arrays in, frozen results out, each step one call (docs/api-example.md walks through it)::

    robot = torquemap.load_robot("robot.toml")
    log = torquemap.read_log("sweep.csv", robot)       # or log_from_columns({...}, robot)
    result = torquemap.identify(robot, log)             # an Identification
    torquemap.save_model("model.toml", result.model)
    forces = torquemap.estimate(result.model, torquemap.read_log("task.csv", robot))
    table = torquemap.pdtv_map(result.model, "a", bins=1024)

``identify``, ``estimate`` and ``pdtv_map`` are also the modules :mod:`torquemap.identify`,
:mod:`torquemap.estimate` and :mod:`torquemap.pdtv_map`; calling the module calls the function
here. Every other name is re-exported from the module that defines it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

from torquemap.estimate import ForceEstimate, Method, estimate_forces
from torquemap.identify import Identification, identify_model
from torquemap.io import Log
from torquemap.model import Model
from torquemap.pdtv_map import PdtvMap
from torquemap.pdtv_map import pdtv_map as _pdtv_map
from torquemap.robot import Robot


def identify(
    robot: Robot | Model,
    logs: Log | Sequence[Log],
    *,
    joints: Sequence[str] | None = None,
    max_order: float | None = None,
    friction: Literal["whole", "passes"] = "whole",
) -> Identification:
    """Identify friction, inertia and PDTV of a robot's joints from no-load logs.

    Parameters
    ----------
    robot
        The robot (:func:`torquemap.load_robot`), or a model whose other joints are kept.
    logs
        One log or several (:func:`torquemap.read_log`), all for this robot.
    joints
        Joint names to identify; default all.
    max_order
        Highest PDTV order [CPR]; default the limit the data resolve.
    friction
        ``"whole"`` (default): friction through zero speed, inertia, PDTV and delay fitted to
        every sample; ``"passes"``: the paper's method, friction from constant-speed passes.

    Returns
    -------
    Identification
        ``.model`` (a :class:`torquemap.model.Model`), per-joint diagnostics and warnings.
        For the full set of options see :func:`torquemap.identify.identify_model`; for logs
        of position holds rather than sweeps, :func:`torquemap.identify_quasi_static`.

    Raises
    ------
    InputError
        On no log, an unknown joint, or logs that do not move the way identification needs.
    """
    seq = [logs] if isinstance(logs, Log) else list(logs)
    return identify_model(robot, seq, joints=joints, max_order=max_order, friction=friction)


def estimate(
    model: Model, log: Log, *, method: Method = "model", cutoff: float = 2.0
) -> ForceEstimate:
    """Estimate the external joint torques (and planar2r end-effector force) of a log.

    Parameters
    ----------
    model
        An identified model (:func:`identify` or :func:`torquemap.load_model`).
    log
        The log, read for ``model.robot``.
    method
        ``"model"`` (default), ``"paper"``, ``"lowpass"`` or ``"raw"``
        (:mod:`torquemap.estimate`).
    cutoff
        Low-pass cut-off [Hz]: the bandwidth of the external force kept.

    Returns
    -------
    ForceEstimate
        ``tau_ext`` [N m, joint side], ``force`` [N] and per-sample flags. For the full set of
        options see :func:`torquemap.estimate.estimate_forces`.
    """
    return estimate_forces(model, log, method=method, cutoff=cutoff)


def pdtv_map(
    model: Model,
    joint: str,
    *,
    bins: int = 1024,
    direction: Literal["mean", "positive", "negative"] = "mean",
) -> PdtvMap:
    """Tabulate a joint's PDTV (anti-cogging feed-forward) over one motor revolution.

    Parameters
    ----------
    model
        The identified model.
    joint
        Joint name.
    bins
        Bins over one motor revolution; bin ``k`` is centred at ``(k + 0.5) 2 pi / bins`` [rad].
    direction
        Directional lines: the ``"mean"`` of both directions, or one direction's.

    Returns
    -------
    PdtvMap
        Motor angle [rad], torque [N m] and current [A] per bin
        (:func:`torquemap.pdtv_map.pdtv_map`; docs/odrive.md and docs/moteus.md for firmware).
    """
    return _pdtv_map(model, joint, bins=bins, direction=direction)

"""Is the arm vertical? A no-load torque that follows the joint angles as gravity would.

Until robot files can say "vertical" (gravity, full rigid-body dynamics), a model describes a
horizontal arm: its no-load torque is inertia, friction and PDTV, the last a function of each
MOTOR angle (``gear_ratio * q``, several cycles per joint revolution). Gravity on a vertical arm
is a function of the absolute LINK angles instead, about one cycle per joint revolution, which
no PDTV line explains. Left in, it becomes an external force on every sample (a vertical
two-link arm described as ``planar2r`` gave 29 N on free motion).

:func:`check_no_load` looks for it in no-load logs with any model (the pass method's, the
whole-log fit's, a hand-written one): the Eq 7 residual (motor torque minus the model's
inertia, friction and PDTV), low-passed over the moving samples alone (:func:`moving_lowpass`:
no torque held at rest leaks into them), is regressed on the cos and sin of the absolute link
angles from the joint on (:func:`gravity_basis`) together with nuisance columns for the parts
of friction a model may miss (a level per direction and one proportional to the speed), on the
samples where the joint moves and does not accelerate much. PDTV lines below one cycle per
motor revolution are left in the residual: the pass method's line picking may have taken the
gravity over a sweep's range for such a line. The torque the gravity columns
explain, peak to peak over the visited poses, is compared with the joint's Coulomb friction;
a chi-square test on their coefficients (with a covariance clustered over one-second blocks, as
the smoothed residual is correlated) says whether it is there at all.

``identify`` (every friction method) refuses a model whose joints hold more than
``REFUSE_SHARE`` of their Coulomb friction, and warns above ``WARN_SHARE``; the result is kept in
the model's notes (``[identification.joints.<j>] gravity_torque``), from which ``estimate``
warns (:func:`model_gravity_warnings`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.filters import lowpass
from torquemap.io import Log
from torquemap.model import Model, PdtvLine, _power_order, pdtv_torque
from torquemap.robust import cluster_jackknife_covariance, cluster_wald_pvalue, weighted_solve

if TYPE_CHECKING:
    from torquemap.filters import Derivatives
    from torquemap.identify import Identification

#: A gravity-like torque above this share of the joint's Coulomb friction is warned about.
WARN_SHARE = 0.1
#: Above this share identification refuses (the model would be wrong by more than half its
#: friction on every sample).
REFUSE_SHARE = 0.5
#: Low-pass [Hz] applied to the residual before the regression (noise, speed ripple).
CUTOFF = 2.0
#: Samples faster than this share of the joint's top speed (99th percentile) are moving: only
#: they are low-passed and tested (:func:`moving_lowpass`).
MOVING_SHARE = 0.05
#: A low-passed sample is kept when at least this share of its filter's weight lies on moving
#: samples.
MOVING_WEIGHT = 0.5
#: PDTV lines of lower order [CPR] are not subtracted before the test: a torque with a period
#: longer than a motor revolution is a joint-angle dependence (the pass method's line picking
#: may take gravity over a sweep's range for such a line).
MIN_ORDER = 1.0
#: Level of the test that the gravity columns explain anything.
SIGNIFICANCE = 1e-6
#: Clusters (1 s blocks of steady motion) beyond the fitted columns the test needs: the
#: cluster-robust covariance has rank at most the number of clusters, so with fewer than the
#: columns it is singular.
MIN_SPARE_CLUSTERS = 2


@dataclass(frozen=True, slots=True, eq=False)
class GravityCheck:
    """Result of the gravity test of one joint.

    Attributes
    ----------
    joint
        Joint name.
    torque
        Peak-to-peak torque explained by the link angles over the visited poses [N m, motor
        side] (0 when the joint did not move enough to test).
    significant
        Whether that torque is statistically there (chi-square at ``SIGNIFICANCE``).
    coulomb
        The joint's Coulomb friction, mean of both directions [N m, motor side].
    samples
        Samples used.
    """

    joint: str
    torque: float
    significant: bool
    coulomb: float
    samples: int

    @property
    def share(self) -> float:
        """``torque / coulomb`` (inf when the model has no friction and a torque was found)."""
        if self.coulomb > 0:
            return self.torque / self.coulomb
        return math.inf if self.torque > 0 else 0.0

    @property
    def warns(self) -> bool:
        """Significant and above ``WARN_SHARE`` of the Coulomb friction."""
        return self.significant and self.share > WARN_SHARE

    @property
    def refuses(self) -> bool:
        """Significant and above ``REFUSE_SHARE`` of the Coulomb friction."""
        return self.significant and self.share > REFUSE_SHARE

    def share_text(self) -> str:
        """The torque against the Coulomb friction, in words when the model has none.

        Examples
        --------
        >>> GravityCheck("j1", 0.2, True, 0.0, 100).share_text()
        'the model has no Coulomb friction to compare with'
        >>> GravityCheck("j1", 0.2, True, 0.4, 100).share_text()
        '50% of its Coulomb friction'
        """
        if self.coulomb > 0:
            return f"{self.share:.0%} of its Coulomb friction"
        return "the model has no Coulomb friction to compare with"

    def message(self) -> str:
        """One line for a warning or a refusal."""
        return (
            f"joint {self.joint}: the no-load torque holds {self.torque:.3g} N m (motor side, "
            f"peak to peak, {self.share_text()}) that depends on the joint "
            "angles as gravity would, which PDTV of the motor angle cannot explain: a vertical "
            "arm? The model has no gravity term; record the no-load logs with the arm "
            "horizontal, or use a robot file that models gravity"
        )


def gravity_basis(q: NDArray[np.float64], k: int, planar: bool) -> NDArray[np.float64]:
    """Columns a gravity torque on joint ``k`` excites: cos and sin of the absolute link angles
    from joint ``k`` on (a planar chain, angles summed) or of joint ``k``'s own angle.

    Examples
    --------
    >>> gravity_basis(np.array([[0.0, 0.5]]), 0, True).round(3).tolist()
    [[1.0, 0.878, 0.0, 0.479]]
    """
    absolute = np.cumsum(q, axis=1)[:, k:] if planar else q[:, k : k + 1]
    return np.column_stack([np.cos(absolute), np.sin(absolute)])


def _coulomb(model: Model, joint: str) -> float:
    law = model.joints[joint].friction
    cp = getattr(law, "coulomb_positive", None)
    cn = getattr(law, "coulomb_negative", None)
    if isinstance(cp, float | int) and isinstance(cn, float | int):
        return 0.5 * (abs(float(cp)) + abs(float(cn)))
    up, down = law.static_levels()
    return 0.5 * (abs(up) + abs(down))


@dataclass(frozen=True, slots=True, eq=False)
class ResidualPiece:
    """One contiguous stretch of a no-load log, seen by a model (one joint).

    Attributes
    ----------
    t
        Time [s], shape (m,).
    q
        Joint angles of the whole robot [rad], shape (m, nj).
    velocity
        Motor velocity [rad/s], shape (m,).
    angle
        Motor angle [rad], shape (m,).
    eq7
        The Eq 7 signal (motor torque minus inertia and friction) [N m, motor side], shape (m,).
    acceleration
        Motor acceleration [rad/s^2], shape (m,).
    free
        ``eq7`` less the model's PDTV torque (every line of the joint) [N m], shape (m,), once
        computed (:func:`with_free`), else None.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    velocity: NDArray[np.float64]
    angle: NDArray[np.float64]
    eq7: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    free: NDArray[np.float64] | None = None


def with_free(
    piece: ResidualPiece, lines: tuple[PdtvLine, ...]
) -> tuple[ResidualPiece, NDArray[np.float64]]:
    """``piece`` with :attr:`ResidualPiece.free` for PDTV ``lines`` (the joint's, every one)
    computed when it is not yet, and that array: the noise levels, the vertical-arm check and
    the residual table each read it."""
    if piece.free is not None:
        return piece, piece.free
    phasor = None
    if sum(1 for line in lines if _power_order(line.order)) > 1 and piece.angle.size:
        # the lines as powers of exp(i theta) (pdtv_torque's kernel): the angle's cosine and
        # sine with an encoder's repeated angles computed once (the same numbers)
        from torquemap._fit_kernels import cos_sin

        phasor = cos_sin(np.ascontiguousarray(piece.angle, dtype=np.float64))
    free = piece.eq7 - pdtv_torque(piece.angle, lines, velocity=piece.velocity, phasor=phasor)
    return dataclasses.replace(piece, free=free), free


#: Pieces of a no-load log shorter than this [s] are left out of the gravity check.
SHORTEST_PIECE = 1.5


def no_load_residuals(
    model: Model,
    logs: Sequence[Log],
    *,
    window: float,
    shortest: float = SHORTEST_PIECE,
    derivatives: Sequence[Sequence[Derivatives]] | None = None,
) -> dict[str, list[ResidualPiece]]:
    """Per joint, the Eq 7 signal of ``model`` over the (sanitised) no-load ``logs``, the torque
    channel's identified delay undone; pieces shorter than ``shortest`` [s] left out.

    ``derivatives``: when ``logs`` are pieces already sanitised (identification's), per piece
    and joint their motor angle's derivatives (:func:`torquemap.filters.differentiate`); the
    pieces are then neither sanitised nor differentiated again.
    """
    from torquemap.delay import shift_channel
    from torquemap.estimate import _signal, identified_delays
    from torquemap.sanitize import sanitize_log

    delays = identified_delays(model)
    robot = model.robot
    out: dict[str, list[ResidualPiece]] = {n: [] for n in robot.joint_names}
    given: list[tuple[Log, Sequence[Derivatives] | None]]
    if derivatives is None:
        given = [
            (piece.log, None) for log in logs for piece in sanitize_log(log, window=window).pieces
        ]
    else:
        given = list(zip(logs, derivatives, strict=True))
    for plog, rates in given:
        if float(plog.t[-1] - plog.t[0]) < shortest:
            continue
        if any(delays.get(name, 0.0) for name in robot.joint_names):
            tau = plog.motor_torque.copy()
            for k, name in enumerate(robot.joint_names):
                if delays.get(name, 0.0):
                    tau[:, k] = shift_channel(plog.t, tau[:, k], delays[name])
            plog = dataclasses.replace(plog, motor_torque=tau)
        try:
            t_est, angle, velocity, acceleration = _signal(model, plog, window=window, rates=rates)
        except InputError:
            continue
        for k, name in enumerate(robot.joint_names):
            out[name].append(
                ResidualPiece(
                    t=plog.t,
                    q=plog.q,
                    velocity=velocity[:, k],
                    angle=angle[:, k],
                    eq7=t_est[:, k],
                    acceleration=acceleration[:, k],
                )
            )
    return out


def check_no_load(
    model: Model,
    logs: Sequence[Log],
    *,
    window: float,
    joints: Sequence[str] | None = None,
    residuals: Mapping[str, Sequence[ResidualPiece]] | None = None,
) -> tuple[GravityCheck, ...]:
    """Test each joint's no-load torque for a gravity-like component the model cannot explain.

    Parameters
    ----------
    model
        The model identified from (or to be checked on) ``logs``.
    logs
        No-load logs of the model's robot.
    window
        Differentiator window [s].
    joints
        Joints to test; default all.
    residuals
        :func:`no_load_residuals` of ``model`` and ``logs`` when already computed.

    Returns
    -------
    tuple of GravityCheck
        One per tested joint, in the robot's order.
    """
    robot = model.robot
    planar = robot.arm.kind == "planar2r"
    names = robot.joint_names if joints is None else tuple(joints)
    if residuals is None:
        residuals = no_load_residuals(model, logs, window=window)
    out: list[GravityCheck] = []
    for k, joint in enumerate(robot.joints):
        if joint.name not in names:
            continue
        jm = model.joints[joint.name]
        # a line slower than one cycle per motor revolution is no motor-angle PDTV (cogging,
        # eccentricity): it may be gravity the line picking took for one
        lines = tuple(line for line in jm.pdtv if line.order >= MIN_ORDER)
        rows: list[tuple[NDArray[np.float64], ...]] = []
        pieces = [
            p for p in residuals.get(joint.name, []) if float(p.t[-1] - p.t[0]) >= 3.0 / CUTOFF
        ]
        levels = [float(np.percentile(np.abs(p.velocity), 99)) for p in pieces]
        top = max(levels, default=0.0)
        tested: list[float] = []  # the levels of the pieces in ``rows``
        for p, level in zip(pieces, levels, strict=True):
            if p.free is not None and lines == jm.pdtv:  # computed already, of these lines
                residual = p.free
            else:
                residual = p.eq7 - pdtv_torque(p.angle, lines, velocity=p.velocity)
            moving = np.abs(p.velocity) > MOVING_SHARE * top
            try:  # one filter pass over both signals and the mask
                low, v_low = moving_lowpass(p.t, np.c_[residual, p.velocity], moving).T
            except InputError:
                continue
            rows.append((p.t, p.q, p.velocity, v_low, low))
            tested.append(level)
        out.append(_test_joint(model, joint.name, k, rows, planar, tested))
    return tuple(out)


def moving_lowpass(
    t: NDArray[np.float64], x: NDArray[np.float64], moving: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """Low-pass ``x`` (shape (n,) or (n, k)) at ``CUTOFF`` over the ``moving`` samples alone
    (normalised convolution):
    ``lowpass(x m) / lowpass(m)`` with ``m`` the mask, NaN where less than ``MOVING_WEIGHT``
    of the filter's weight lies on moving samples.

    At rest (and through a reversal) a drive holds a torque no friction law of the speed
    knows (stiction, a position loop's integral), and below its slowest pass a model's law is
    not measured: a plain low-pass mixes that misfit into the steady samples next to the
    rests, at the ends of the swept range, where it follows the joint angle as gravity would
    (random SCARA 102, horizontal, thinned to 285 Hz with gaps: warned a vertical arm at 34 %
    of its friction; 2 % with this filter).

    Examples
    --------
    >>> t = np.arange(0.0, 4.0, 1e-3)
    >>> moving = np.abs(t - 2.0) > 0.2
    >>> x = np.where(moving, 1.0, 50.0)  # a wild torque at rest
    >>> low = moving_lowpass(t, x, moving)
    >>> bool(np.nanmax(np.abs(low - 1.0)) < 1e-6), bool(np.isnan(low[2000]))
    (True, True)
    """
    columns = x.reshape(x.shape[0], -1)
    # the mask and the masked signals through one call (the filter acts on each column alike)
    both = lowpass(
        t, np.c_[moving.astype(np.float64), np.where(moving[:, None], columns, 0.0)], cutoff=CUTOFF
    )
    weight, low = both[:, :1], both[:, 1:]
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(weight >= MOVING_WEIGHT, low / weight, np.nan)
    return out.reshape(x.shape)


def _test_joint(
    model: Model,
    name: str,
    k: int,
    pieces: list[tuple[NDArray[np.float64], ...]],
    planar: bool,
    levels: Sequence[float] | None = None,
) -> GravityCheck:
    """The gravity test of joint ``name`` on ``pieces`` (time, joint angles, speed, low-passed
    speed, low-passed residual); ``levels``: each piece's 99th percentile of the absolute
    speed when already computed."""
    coulomb = _coulomb(model, name)
    none = GravityCheck(joint=name, torque=0.0, significant=False, coulomb=coulomb, samples=0)
    if not pieces:
        return none
    if levels is None:
        levels = [float(np.percentile(np.abs(p[2]), 99)) for p in pieces]
    top = max(levels)
    if not top > 0:
        return none
    cols, ys, clusters, visited = [], [], [], []
    offset = 0
    for t, q, v, v_low, low in pieces:
        visited.append(q[np.abs(v) > MOVING_SHARE * top])
        # moving steadily: well away from rest (friction's sign known) and the low-passed speed
        # close to the speed (no ramp, whose inertia error would follow the range's ends)
        use = (np.abs(v) > MOVING_SHARE * top) & (np.abs(v - v_low) < 0.2 * np.abs(v) + 1e-12)
        with np.errstate(invalid="ignore"):
            use &= np.abs(np.gradient(v_low, t)) * 0.5 < 0.2 * np.abs(v_low)
        use &= np.isfinite(low)
        r = np.flatnonzero(use)
        if r.size < 20:
            continue
        vv = v[r]
        nuisance = np.column_stack([(vv > 0).astype(float), (vv < 0).astype(float), vv])
        cols.append(np.hstack((nuisance, gravity_basis(q[r], k, planar))))
        ys.append(low[r])
        block = np.floor((t[r] - t[0]) / 1.0).astype(np.int64)
        clusters.append(block + offset)
        offset += int(block.max()) + 1
    if not cols:
        return none
    a = np.vstack(cols)
    y = np.concatenate(ys)
    if y.size < 50:
        return none
    groups = np.concatenate(clusters)
    if np.unique(groups).size < a.shape[1] + MIN_SPARE_CLUSTERS:
        # the cluster-robust covariance is a sum of one outer product per cluster (1 s blocks
        # of steady motion): with fewer clusters than columns it is singular and any torque
        # looks significant (and poses barely visited make the gravity columns collinear):
        # too short to test
        return GravityCheck(
            joint=name, torque=0.0, significant=False, coulomb=coulomb, samples=int(y.size)
        )
    w = np.ones(y.size)
    coef, _ = weighted_solve(a, y, w)
    # leave-one-cluster-out covariance and the F(m, G - 1) reference: with few 1 s clusters
    # the sandwich is too small and the chi-square over-rejects (random SCARA 76, no gravity:
    # 14 clusters, sandwich and chi-square p 1e-11, refused; tests/test_robust.py)
    cov = cluster_jackknife_covariance(a, y, w, groups)
    c = coef[3:]
    # the fitted gravity torque over every pose the joint moved through (ramps included)
    torque = gravity_basis(np.vstack(visited), k, planar) @ c
    ptp = float(np.percentile(torque, 99.9) - np.percentile(torque, 0.1))
    significant = bool(cluster_wald_pvalue(c, cov[3:, 3:], np.unique(groups).size) < SIGNIFICANCE)
    return GravityCheck(
        joint=name, torque=ptp, significant=significant, coulomb=coulomb, samples=int(y.size)
    )


def gravity_notes(checks: Sequence[GravityCheck]) -> dict[str, dict[str, float | bool]]:
    """``[identification.joints.<j>]`` entries recording the checks (docs/formats.md)."""
    return {
        c.joint: {"gravity_torque": float(c.torque), "gravity_significant": c.significant}
        for c in checks
    }


def checked_identification(
    ident: Identification,
    logs: Sequence[Log],
    *,
    window: float,
    vertical: Literal["refuse", "warn"] = "refuse",
    path: str | None = None,
    derivatives: Sequence[Sequence[Derivatives]] | None = None,
    residuals: Mapping[str, Sequence[ResidualPiece]] | None = None,
) -> Identification:
    """Run :func:`check_no_load` on an identification's model and its (sanitised) logs:
    refuse (``vertical="refuse"``, InputError naming ``path``) or warn, and record the result
    in the model's notes; for joints without a parameter covariance, also record the no-load
    residual's level per speed (:func:`torquemap.uncertainty.residual_table`), estimation's
    sigma. Used by :func:`torquemap.identify.identify_model` for every friction method.
    ``derivatives``: those of the pieces' motor angles, when ``logs`` are sanitised pieces
    (:func:`no_load_residuals`). ``residuals``: :func:`no_load_residuals` of the model and
    ``logs`` when already computed (pieces of any length: those shorter than
    ``SHORTEST_PIECE`` are left out here, as :func:`no_load_residuals` leaves them out)."""
    model = ident.model
    if residuals is None:
        residuals = no_load_residuals(model, logs, window=window, derivatives=derivatives)
    # the residual less PDTV of the joints whose residual table is recorded below, once for
    # that table and the check
    noted = model.notes.get("joints", {})
    tabled = {
        name
        for name in ident.joints
        if not (isinstance(noted.get(name), Mapping) and "uncertainty" in noted[name])
    }
    residuals = {
        name: [
            with_free(p, model.joints[name].pdtv)[0] if name in tabled else p
            for p in parts
            if not float(p.t[-1] - p.t[0]) < SHORTEST_PIECE
        ]
        for name, parts in residuals.items()
    }
    checks = check_no_load(
        model, logs, window=window, joints=tuple(ident.joints), residuals=residuals
    )
    for c in checks:
        if vertical == "refuse" and c.refuses:
            misfit = f"joint {c.joint}: the pass model does not explain the sweep"
            if any(w.startswith(misfit) for w in ident.warnings):
                # the test assumes the model's friction and inertia are right: a pass model
                # that misses its own sweep (a friction law of another form, a delay) leaves a
                # residual that can follow the joint angles without any gravity
                raise InputError(
                    f"{c.message()}; or the pass model is wrong (it does not explain the sweep, "
                    "ramps included, which can look like gravity): identify with the default "
                    "--friction whole first",
                    path=path,
                )
            raise InputError(c.message(), path=path)
    # the whole-log fit tests for gravity too (in its own regression): one line per joint
    said = {
        c.joint
        for c in checks
        for w in ident.warnings
        if w.startswith(f"joint {c.joint}: the no-load torque holds")
    }
    added = [c.message() for c in checks if c.warns and c.joint not in said]
    notes = dict(model.notes)
    joints: dict[str, dict[str, Any]] = {k: dict(v) for k, v in notes.get("joints", {}).items()}
    for name, entry in gravity_notes(checks).items():
        joints.setdefault(name, {}).update(entry)
    # joints without a parameter covariance (the pass method, a whole fit that fell back to
    # it): the no-load residual's level per speed is their estimate's uncertainty
    from torquemap.estimate import _bands
    from torquemap.uncertainty import residual_table

    bands = _bands(dataclasses.replace(model, notes=notes), None)
    for name in ident.joints:
        record = joints.setdefault(name, {})
        if "uncertainty" in record:
            continue
        lines = model.joints[name].pdtv
        pieces = residuals.get(name, [])
        table = residual_table(
            [p.t for p in pieces],
            [p.velocity for p in pieces],
            [p.acceleration for p in pieces],
            [with_free(p, lines)[1] for p in pieces],
            band=bands[name],
        )
        if table is not None:
            record["uncertainty"] = table
    notes["joints"] = joints
    warnings = [*ident.warnings, *(w for w in added if w not in ident.warnings)]
    notes["warnings"] = list(warnings)
    return dataclasses.replace(
        ident, model=dataclasses.replace(model, notes=notes), warnings=tuple(warnings)
    )


def model_gravity_warnings(model: Model) -> list[str]:
    """Warnings for the joints whose identification found a gravity-like no-load torque above
    ``WARN_SHARE`` of their friction (the model's notes; nothing for models without them)."""
    out: list[str] = []
    joints = model.notes.get("joints", {})
    if not isinstance(joints, Mapping):
        return out
    for joint in model.robot.joint_names:
        entry = joints.get(joint)
        if not isinstance(entry, Mapping) or joint not in model.joints:
            continue
        torque = entry.get("gravity_torque")
        if not isinstance(torque, int | float) or not math.isfinite(torque) or torque <= 0:
            continue
        if entry.get("gravity_significant") is False:
            continue
        check = GravityCheck(
            joint=joint,
            torque=float(torque),
            significant=True,
            coulomb=_coulomb(model, joint),
            samples=0,
        )
        if check.warns:
            out.append(
                check.message().replace(
                    "the no-load torque", "identification found the no-load torque"
                )
                + "; the forces hold that torque as if it were external"
            )
    return out

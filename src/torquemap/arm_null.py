"""External joint torques that no end-effector wrench gives (new-user QA, stop 37; docs/arm.md).

An arm with more joints than its wrench has components (a 7-axis arm, a 6-component wrench)
has torques no wrench on the end effector can give: those along the null space of its
Jacobian, ``n`` with ``J n = 0``, since ``n . J^T w = (J n) . w = 0``. An estimate whose
external torques hold such a component beyond their sigmas is not of a contact at the end
effector: contact elsewhere on the arm, or a log whose joint columns are swapped or of another
robot. On the Panda bench, a task log with joints 2 and 3 swapped gave a 104 N median force
(the truth 13 N) with no warning; the component was beyond 3 sigmas at 97 % of its samples
(joints 5 and 6 swapped: 60 %), at none of the log's own.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

#: A sample's null-space component is beyond its sigmas when its chi-square exceeds this
#: quantile of the chi-square distribution (3 sigmas for one degree of freedom).
NULL_QUANTILE = 0.9973
#: Warned when more than this share of the sound samples is beyond (0 % on the Panda bench's
#: own task log; 60 % and 97 % with two joints' columns swapped).
NULL_SHARE = 0.2


def null_space_share(
    jacobian: NDArray[np.float64],
    tau_ext: NDArray[np.float64],
    sigma: NDArray[np.float64],
    keep: NDArray[np.bool_],
) -> float | None:
    """The share of the ``keep`` samples whose external torques' component along the null
    space of the Jacobian exceeds its sigmas (chi-square above :data:`NULL_QUANTILE`), or None
    when the arm has no such space (no more joints than wrench components) or no sample is kept.

    Parameters
    ----------
    jacobian
        (n, axes, nj) end-effector Jacobians [m or -].
    tau_ext, sigma
        (n, nj) external joint torques and their standard deviations [N m or N].
    keep
        (n,) the samples to judge (sound, away from the filters' edges).
    """
    _, axes, nj = jacobian.shape
    if nj <= axes or not keep.any():
        return None
    J = jacobian[keep]
    vt = np.linalg.svd(J)[2]
    d = nj - axes
    basis = vt[:, axes:, :]  # (m, d, nj): rows spanning J's null space
    t = tau_ext[keep]
    s2 = sigma[keep] ** 2
    component = np.einsum("mdj,mj->md", basis, t)
    cov = np.einsum("mdj,mej,mj->mde", basis, basis, s2)
    cov += 1e-300 * np.eye(d)  # a zero sigma: an infinite statistic, not a singular solve
    stat = np.einsum("md,md->m", component, np.linalg.solve(cov, component[..., None])[..., 0])
    ok = np.isfinite(stat)
    if not ok.any():
        return None
    return float(np.mean(stat[ok] > chi2.ppf(NULL_QUANTILE, d)))


def null_space_message(share: float) -> str | None:
    """The warning for :func:`null_space_share`'s ``share``, or None below :data:`NULL_SHARE`."""
    if share <= NULL_SHARE:
        return None
    return (
        f"at {share:.0%} of the samples the external joint torques hold a part no wrench on the "
        "end effector gives (beyond 3 sigmas): contact elsewhere on the arm, or are the log's "
        "joint columns swapped, a joint's current logged with its sign flipped, or of another "
        "robot? The wrench is then wrong"
    )

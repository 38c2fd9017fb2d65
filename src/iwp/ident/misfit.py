"""Whether the residuals of a regression of section 5 hold a term the model lacks, or only noise.

The residuals of the regression (13) on differentiated encoder logs are the
encoder noise passed through the differentiator when the model is right, and
that noise plus a function of the rig's state and input when the model misses
a term. Their *level* alone cannot tell the two apart: sensor noise that is
correlated in time (an AR(1) process of 20 ms, say) puts far more power into
the low band the differentiator keeps than its white level, measured from the
positions' fourth difference, predicts, and a correct model's residuals then
stand 2.5-3 times above that level on every log (issue 50).

What noise cannot do is follow the state: sensor noise is independent of the
rig's motion. :func:`residual_structure` therefore fits the residuals of each
row of (10) with a library of the terms a rig of this kind may add to model
(9) -- Coulomb friction and quadratic drag of either joint (``sgn q3``,
``q3 |q3|``, ``sgn q4``, ``q4 |q4|``), a residue of the dead zone or a
nonlinear drive (``sgn u``, ``u |u|``), a drive that lags the command (a
flexible belt, a delay: ``du/dt``) -- evaluated on the filtered signals, and
reports the share of the residuals' variance they explain. Noise of any
spectrum leaves that share near ``k / n_eff`` (a few per cent); a missing
term explains most of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .setups import Regression
from .signals import Signals

__all__ = ["ResidualStructure", "residual_structure", "STRUCTURE_EXPLAINED"]

#: the share of a row's residual variance that the library must explain for the residuals to hold a term the model
#: lacks (noise leaves k / n_eff of it: 0.2-2 % on 20-60 s logs; a missing wheel Coulomb friction 70-99 %)
STRUCTURE_EXPLAINED = 0.5


@dataclass(frozen=True)
class ResidualStructure:
    """What the library explains of each row's residuals.

    Attributes
    ----------
    explained : dict of str to float
        Per row label (``"q3"``, ``"q4"``): the share of the residuals' variance the library explains, in [0, 1].
    leading : dict of str to list of str
        Per row label: the library's terms that explain the most alone, best first (those explaining a tenth
        or more).
    """

    explained: dict[str, float]
    leading: dict[str, list[str]]

    def holds_a_term(self, label: str) -> bool:
        """The row's residuals follow the state or input: a term the model lacks (:data:`STRUCTURE_EXPLAINED`)."""
        return self.explained.get(label, 0.0) >= STRUCTURE_EXPLAINED

    def describe(self, label: str) -> str:
        """A clause on the row's residuals."""
        share = 100.0 * self.explained.get(label, 0.0)
        terms = self.leading.get(label, [])
        if not terms:
            return f"the terms a rig may add explain {share:.0f} % of them"
        return f"{share:.0f} % of them follow {' and '.join(terms)} (a term the model lacks: {_MEANING[terms[0]]})"


#: what each library term stands for on a rig
_MEANING = {
    "sgn q3": "Coulomb friction of the pendulum",
    "q3 |q3|": "air drag of the pendulum",
    "sgn q4": "Coulomb friction of the wheel",
    "q4 |q4|": "drag of the wheel",
    "sgn u": "a dead-zone residue of the drive",
    "u |u|": "a drive whose gain changes with the command",
    "du/dt": "a drive that lags the command: a flexible belt, a delay, or an input read with the wrong hold",
}


def _library(sig: Signals) -> dict[str, np.ndarray]:
    """The candidate terms on the stacked filtered signals (those that vary)."""
    q3, q4, u = sig.q3, sig.q4, sig.u
    du = np.zeros_like(u)
    for k, f in enumerate(sig.files):  # within each file (the stacked signals join files end to end)
        rows = sig.file_rows(k)
        seg = u[rows]
        if seg.size > 2:
            du[rows] = np.gradient(seg, f["Ts"])
    lib = {"sgn q3": np.sign(q3), "q3 |q3|": q3 * np.abs(q3), "sgn q4": np.sign(q4), "q4 |q4|": q4 * np.abs(q4),
           "sgn u": np.sign(u), "u |u|": u * np.abs(u), "du/dt": du}
    return {k: v for k, v in lib.items() if np.ptp(v) > 0 and np.all(np.isfinite(v))}


def residual_structure(sig: Signals, reg: Regression, theta: np.ndarray) -> ResidualStructure:
    """The share of each row's residual variance that a library of the terms a rig may add explains.

    Each row of (10) is fitted again with its own columns and the library's (:mod:`iwp.ident.misfit`); the share
    is ``1 - RSS_with / RSS_without``.

    Parameters
    ----------
    sig : Signals
        The stacked filtered signals (:func:`~iwp.ident.signals.prepare_signals`).
    reg : Regression
        The set-up's regression (one block of ``sig.n`` rows per label).
    theta : ndarray
        The estimates of ``reg``'s columns.

    Returns
    -------
    ResidualStructure
    """
    lib = _library(sig)
    names = list(lib)
    L = np.column_stack([lib[n] for n in names]) if names else np.zeros((sig.n, 0))
    r_all = reg.phi - reg.Phi @ theta
    explained: dict[str, float] = {}
    leading: dict[str, list[str]] = {}
    n = sig.n
    for b, label in enumerate(reg.labels):
        rows = slice(b * n, (b + 1) * n) if reg.Phi.shape[0] == n * len(reg.labels) else slice(None)
        r = r_all[rows]
        own = reg.Phi[rows]
        own = own[:, np.any(own != 0.0, axis=0)]
        rss = float(r @ r)
        if not names or rss <= 0.0:
            explained[label], leading[label] = 0.0, []
            continue
        X = np.column_stack([own, L])
        scale = np.linalg.norm(X, axis=0)
        scale[scale == 0] = 1.0
        coef, *_ = np.linalg.lstsq(X / scale, r, rcond=None)
        e = r - (X / scale) @ coef
        explained[label] = float(min(max(1.0 - float(e @ e) / rss, 0.0), 1.0))
        alone = {}
        for j, name in enumerate(names):
            Xj = np.column_stack([own, L[:, j]])
            sj = np.linalg.norm(Xj, axis=0)
            sj[sj == 0] = 1.0
            cj, *_ = np.linalg.lstsq(Xj / sj, r, rcond=None)
            ej = r - (Xj / sj) @ cj
            alone[name] = 1.0 - float(ej @ ej) / rss
        leading[label] = [k for k in sorted(alone, key=alone.get, reverse=True) if alone[k] >= 0.1][:2]
    return ResidualStructure(explained, leading)


def correlated_note(ratio: float, row: str, chan: str, structure: ResidualStructure, label: str) -> str:
    """Why residuals above the white noise level are taken as correlated noise, not a missing term."""
    return (f"the residuals of the {row} row of (10) are {ratio:.3g} times what white noise at the level of encoder "
            f"{chan}'s fourth difference explains, but {structure.describe(label)}: noise correlated in time (it puts "
            "more power in the band the differentiator keeps than its white level), not a term the model lacks. "
            "Standard errors from the HAC covariance, which the residuals' own correlation sets")

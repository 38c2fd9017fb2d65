"""Plain words for the statistics and references the pages name: what a reader needs on first meeting them.

The identification's summaries name their statistics the way a
statistician would ("HAC sandwich (Bartlett, 919 lags)"); the pages say
each in short plain sentences where it first appears (:func:`intervals_in_words`),
and the paper's errata are explained where they are cited (:data:`ERRATA`,
linked from every "ERRATA item N" by :func:`iwp.report.page.render_html`).
"""

from __future__ import annotations

import re

__all__ = ["ERRATA", "ERRATA_SOURCE", "intervals_in_words"]

#: Where the paper disagrees with itself, one plain sentence per item (docs/errata.md holds the table).
ERRATA: dict[int, str] = {
    1: "Section 5.2, set-up (d): the pendulum's rolling-friction term is printed as sigma_a1 |cos q1| without its "
       "factor q3; iwp uses sigma_a1 |cos q1| q3, as in the paper's equation (9).",
    2: "Section 5.2: the printed rho_1 = 246.33 and rho_2 = 249.63 are the ratios theta3/theta1 and "
       "theta4/theta2 without the '- 1' that the derivation has; iwp computes them as derived.",
    3: "Equation (16) prints theta7 = 2.6060 and theta8 = 7.1394, the sentence after it 2.5194 and 7.2813; a "
       "reproduced value is compared with either.",
    4: "The free pendulum is released from q1 = -1.422 rad in the text and from -1.442 rad in the caption of "
       "figure 8; the virtual rig uses the text's value.",
    5: "Table 1 rounds sigma_b1 to 0.0005 where the identification gave 0.00047; iwp keeps Table 1 as printed.",
    6: "Section 5.1, set-up (b): the regressor is written with the raw input v where the model it identifies uses "
       "the compensated input u; iwp uses u.",
}

#: Where the errata are kept in the source tree.
ERRATA_SOURCE = "docs/errata.md"


def intervals_in_words(method: str, Ts: float | None = None, *, brief: bool = False) -> str:
    """Short plain sentences on how a fit's 95 % intervals were computed, from its summary (``Reliability.method``).

    Parameters
    ----------
    method : str
        The method as the fit describes it (e.g. ``"HAC sandwich (Bartlett, 919 lags)"``).
    Ts : float, optional
        Sample time of the logs [s], to give the lags in seconds.
    brief : bool, default False
        The method was explained before on the page: say only what differs (the lags).

    Returns
    -------
    str
        The sentences; empty if the method is not one of those known (or, ``brief``, has nothing to add).
    """
    text = method or ""
    if "HAC" in text:
        m = re.search(r"(\d+) lags", text)
        lags = ""
        if m:
            n = int(m.group(1))
            lags = f" up to {n} samples apart" + (f" ({n * Ts:.3g} s)" if Ts else "")
        if brief:
            return f"Here the residuals' correlation is taken{lags}." if lags else ""
        return ("How the 95 % intervals are computed: the misfit of the model is not independent from sample to "
                f"sample, so the spread of the estimates is computed from the residuals and their correlation{lags}, "
                "each lag weighted less the further apart (Bartlett's weights). Statisticians call this a HAC "
                "(heteroscedasticity and autocorrelation consistent) sandwich covariance.")
    if brief:
        return ""
    if "spread across" in text:
        return ("How the 95 % intervals are computed: from how much the estimates differ between the experiments, "
                "each experiment counting as one independent draw, with a Student t factor for their small number "
                "(its degrees of freedom by Bell and McCaffrey's correction).")
    if "white" in text:
        return ("How the 95 % intervals are computed: from the residuals' spread, as if each sample's misfit were "
                "independent of the others (white residuals).")
    return ""

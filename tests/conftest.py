import os

import matplotlib

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402

import iwp.reproduce.context as context  # noqa: E402  (where the pipeline saves its figures)
from iwp.reproduce import reproduce  # noqa: E402
from tests.helpers import keeping_figures  # noqa: E402


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    """One reduced run of the whole ``iwp reproduce`` pipeline per session, its figures' artists kept."""
    out = tmp_path_factory.mktemp("reproduce") / "out"
    events = []
    with keeping_figures(context) as figures:
        res = reproduce(out, quick=True, progress=events.append)
    return {"result": res, "out": out, "figures": figures, "events": events}

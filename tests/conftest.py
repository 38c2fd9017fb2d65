import os

import matplotlib

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402

import iwp.reproduce.context as context  # noqa: E402  (where the pipeline saves its figures)
from iwp.reproduce import reproduce  # noqa: E402


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    """One reduced run of the whole ``iwp reproduce`` pipeline per session, its figures' artists kept."""
    out = tmp_path_factory.mktemp("reproduce") / "out"
    figures = {}
    events = []
    orig = context.save_figure

    def keep(fig, out_dir, name, **kw):
        figures[name] = fig
        return orig(fig, out_dir, name, **kw)

    mp = pytest.MonkeyPatch()
    mp.setattr(context, "save_figure", keep)
    try:
        res = reproduce(out, quick=True, progress=events.append)
    finally:
        mp.undo()
    return {"result": res, "out": out, "figures": figures, "events": events}

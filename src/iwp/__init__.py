"""iwp: the inertia wheel pendulum toolkit.

Simulate the rig or its virtual twin, identify its parameters from encoder
logs, compensate its motor dead zone, control it, and show how well the model
predicts reality. The equations follow "Modelling an inertia wheel pendulum
benchmark" (the paper); docstrings cite its equation numbers.
"""

from __future__ import annotations

__version__ = "0.1.0"

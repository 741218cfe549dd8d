"""The estimation package's names and constants that need none of its code: what a command line's
``--help`` says (the estimators' names, the paper's time per speed) without importing scipy.

The registry (:mod:`jointwear_ros.estimation.registry`) checks that its built-in estimators are
:data:`ESTIMATOR_NAMES`, in this order, so the two cannot drift.

>>> ESTIMATOR_NAMES
('paper', 'paper-grid', 'bayes', 'joint')
"""

from __future__ import annotations

__all__ = ["ESTIMATOR_NAMES", "PAPER_SECONDS_PER_SPEED"]

#: The built-in wear estimators by name, in the registry's order (an installed package may add more).
ESTIMATOR_NAMES: tuple[str, ...] = ("paper", "paper-grid", "bayes", "joint")

#: Seconds one speed took in the paper's experiments (forward and reverse, Section 2).
PAPER_SECONDS_PER_SPEED = 14.0

"""The library of candidate effects.

A candidate is a :class:`~jointwear_ros.model.Term` that can be added on top of
a model. Three kinds:

* the paper's own terms that say they are candidates
  (:attr:`~jointwear_ros.model.Term.candidate`: ``load_coulomb``,
  ``load_stribeck``, ``temp_stribeck``, ``temp_viscous``, ``wear_stribeck``,
  ``wear_viscous``) when the data has their inputs and the model does not hold
  them yet;
* the shapes of :mod:`jointwear_ros.model.shapes` (one registry, :data:`~jointwear_ros.model.shapes.SHAPES`):
  generic terms of ANY numeric column ``x`` of the data, named ``shape(x)``
  (``lin``, ``x_stribeck``, ``x_viscous``, ``exp_viscous``, ``ripple`` for
  angle-like columns, ``inter(x,y)`` with load and temperature), and the
  fitted shapes the diagnosis starts from the evidence;
* user terms (``extra``): a small :class:`~jointwear_ros.model.Term` subclass, resolved from its
  spec string by :func:`jointwear_ros.model.resolve_term` (dotted path ``pkg.module:ClassName``
  or a name in the entry point group ``jointwear.terms``).

A term's workbench knowledge (the parameters it is linear in, its starting
points in the data's units, what it means) is on the term itself
(:attr:`~jointwear_ros.model.Term.linear`, :meth:`~jointwear_ros.model.Term.guess`,
:meth:`~jointwear_ros.model.Term.describe_effect`). The library only proposes
candidates; choosing among them is :mod:`jointwear_ros.workbench.diagnose`'s job.

>>> from jointwear_ros.model import parse_spec
>>> import numpy as np
>>> table = ObservationTable({"speed": np.array([1.0, 2.0]), "tau_f": np.array([0.1, 0.1]),
...                           "lube_hours": np.array([0.0, 5.0])})
>>> [t.name for t in candidate_library(table, parse_spec("standard"))][:3]
['lin(lube_hours)', 'x_stribeck(lube_hours)', 'x_viscous(lube_hours)']
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..model import TERMS, Model, Term
from ..model.shapes import IDENT, SHAPES, Interaction
from ..types import ObservationTable

__all__ = [
    "NON_CANDIDATE_COLUMNS",
    "candidate_library",
    "candidate_variables",
]

#: Columns never used as a candidate's variable: the response, its parts and ids.
NON_CANDIDATE_COLUMNS = frozenset({"speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "cycle", "production"})

# generic candidates that would only repeat a paper term (load_torque >= 0)
_DUPLICATES = {"lin(load_torque)": "load_coulomb", "x_stribeck(load_torque)": "load_stribeck"}


# -- the library --------------------------------------------------------------
def candidate_variables(table: ObservationTable) -> list[str]:
    """Columns usable as a candidate's variable: numeric, finite, not constant, not the response."""
    out = []
    for name, col in table.columns.items():
        if name in NON_CANDIDATE_COLUMNS or not IDENT.match(name):
            continue
        if col.size == 0 or not np.all(np.isfinite(col)) or float(np.ptp(col)) == 0.0:
            continue
        out.append(name)
    return out


def candidate_library(
    table: ObservationTable,
    model: Model,
    *,
    extra: Sequence[Term] = (),
    variables: Sequence[str] | None = None,
    shapes: Callable[[str], Sequence[str]] | None = None,
    generic: Sequence[str] | None = None,
) -> list[Term]:
    """Candidate terms to try on top of ``model`` for this data.

    Paper terms whose inputs the data has, the library's shapes
    (:meth:`~.shapes.CandidateTerm.offered_for`) of every usable column (the
    ripple only for angle-like columns), interactions with load and
    temperature, and ``extra`` (user terms). Terms already in the model, and
    generic terms that would repeat a paper term, are left out. ``generic``
    (default: every usable column) limits the generic shapes and
    interactions to those columns; the paper terms are offered whenever the
    data has their inputs.
    """
    have = set(model.term_names)
    all_vars = list(variables) if variables is not None else candidate_variables(table)
    usable = set(all_vars) | {"speed"}
    vars_ = [v for v in all_vars if generic is None or v in generic]
    out: list[Term] = []
    for name, cls in TERMS.items():
        term = cls()
        if term.candidate and name not in have and set(term.variables) <= usable:
            out.append(term)
    for v in vars_:
        names = shapes(v) if shapes is not None else [s for s, c in SHAPES.items() if c.offered_for(v)]
        for s in names:
            term = SHAPES[s](v)
            dup = _DUPLICATES.get(term.name)
            if term.name in have or (dup is not None and dup in {t.name for t in out} | have):
                continue
            out.append(term)
    partners: list[str] = [v for v in ("load_torque", "temperature") if v in vars_]
    pairs: list[tuple[str, str]] = []
    for partner in partners:
        for v in vars_:
            if v != partner and (partner, v) not in pairs and (v, partner) not in pairs:
                pairs.append((v, partner))
    for v, y in pairs:
        term = Interaction(v, y)
        if term.name not in have:
            out.append(term)
    seen = {t.name for t in out}
    out.extend(t for t in extra if t.name not in have and t.name not in seen)
    return out

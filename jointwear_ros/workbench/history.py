"""A JSON history of model versions and their errors, to watch the error fall.

The file holds ``{"format": "jointwear-model-history/1", "versions": [...]}``;
each version records the model spec, its RMSE, CV RMSE, AIC, BIC, RMSE per
speed band, the parameter values, the data it was fitted to and when.
Written atomically (temporary file, then rename).

>>> import tempfile, pathlib
>>> from jointwear_ros.data import synth_observations
>>> from jointwear_ros.model import parse_model_spec
>>> from jointwear_ros.workbench import fit_model
>>> data = synth_observations(n_cycles=4, seed=0)
>>> h = History(pathlib.Path(tempfile.mkdtemp()) / "history.json")
>>> for spec in ("standard", "paper"):
...     m = parse_model_spec(spec)
...     _ = h.add(fit_model(m, data, m.make_params()), data)
>>> _ = h.save()
>>> [(v.version, v.model) for v in History.load(h.path).versions]
[(1, 'coulomb + stribeck + viscous'), (2, 'coulomb + load_coulomb + load_stribeck + temp_stribeck + temp_viscous')]
>>> h.versions[1].rmse < h.versions[0].rmse / 5
True
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputDataError
from ..types import ObservationTable
from .compare import band_rmse, noise_floor
from .fit import FitResult

__all__ = ["HISTORY_FORMAT", "History", "ModelVersion"]

HISTORY_FORMAT = "jointwear-model-history/1"


def _num(x: Any) -> float | None:
    f = float(x)
    return f if math.isfinite(f) else None


@dataclass
class ModelVersion:
    """One model version: its spec and errors on one data set."""

    version: int
    model: str
    rmse: float | None
    cv_rmse: float | None
    aic: float | None
    bic: float | None
    n: int
    n_free: int
    noise_floor: float | None
    bands: dict[str, float | None] = field(default_factory=dict)
    params: dict[str, float] = field(default_factory=dict)
    data: str = ""
    note: str = ""
    created: str = ""

    @classmethod
    def from_fit(cls, fit: FitResult, table: ObservationTable, version: int = 0, note: str = "") -> ModelVersion:
        nf, _ = noise_floor(table)
        return cls(
            version=version,
            model=fit.spec,
            rmse=_num(fit.rmse),
            cv_rmse=_num(fit.cv_rmse),
            aic=_num(fit.aic),
            bic=_num(fit.bic),
            n=fit.n,
            n_free=fit.n_free,
            noise_floor=_num(nf),
            bands={b.label: _num(b.rmse) for b in band_rmse(table.speed, fit.residuals)},
            params={n: p.value for n, p in fit.params.items()},
            data=table.source,
            note=note,
            created=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        )


class History:
    """Model versions in a JSON file (created on first save)."""

    def __init__(self, path: str | os.PathLike[str] | None = None, versions: list[ModelVersion] | None = None):
        self.path = Path(path) if path is not None else None
        self.versions: list[ModelVersion] = list(versions or [])

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> History:
        """Read a history file; a missing file is an empty history."""
        p = Path(path)
        if not p.exists():
            return cls(p)
        try:
            doc = json.loads(p.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputDataError(f"{p}: not a readable model history JSON ({exc}); give a new file name") from None
        if not isinstance(doc, dict) or doc.get("format") != HISTORY_FORMAT or not isinstance(doc.get("versions"), list):
            raise InputDataError(f"{p}: not a jointwear model history (expected format {HISTORY_FORMAT!r})")
        out = []
        names = {f for f in ModelVersion.__dataclass_fields__}
        for i, v in enumerate(doc["versions"], start=1):
            if not isinstance(v, dict) or "model" not in v:
                raise InputDataError(f"{p}: version entry {i} is malformed (no 'model')")
            try:
                out.append(ModelVersion(**{k: v[k] for k in v if k in names}))
            except TypeError as exc:
                raise InputDataError(f"{p}: version entry {i} is malformed ({exc})") from None
        return cls(p, out)

    def add(self, fit: FitResult, table: ObservationTable, note: str = "") -> ModelVersion:
        v = ModelVersion.from_fit(fit, table, version=len(self.versions) + 1, note=note)
        self.versions.append(v)
        return v

    @property
    def last(self) -> ModelVersion | None:
        return self.versions[-1] if self.versions else None

    def to_dict(self) -> dict[str, Any]:
        return {"format": HISTORY_FORMAT, "versions": [asdict(v) for v in self.versions]}

    def save(self, path: str | os.PathLike[str] | None = None) -> Path:
        p = Path(path) if path is not None else self.path
        if p is None:
            raise InputDataError("history has no file name to save to")
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=p.name + ".", suffix=".tmp", dir=p.parent)
        try:
            with os.fdopen(fd, "w") as fh:
                json.dump(self.to_dict(), fh, indent=2)
                fh.write("\n")
            os.replace(tmp, p)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        self.path = p
        return p

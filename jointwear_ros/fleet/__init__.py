"""A fleet's wear history re-analysed: bags replayed on Dask into the history store, versions compared, a page.

- :mod:`.reanalysis`: one bag through the same cores as ``jointwear replay``, plain records out.
- :mod:`.driver`: the Dask driver (LocalCluster or an existing scheduler), resumable, into the store.
- :mod:`.ledger`: which bags an analysis version has done (a table beside the estimates).
- :mod:`.compare`: the joints whose level or time to alarm changed between two analysis versions.
- :mod:`.report`: the static HTML fleet page.
- :mod:`.synthetic_bags`: nightly bags of a synthetic fleet in the recorder's format (tests, benchmarks).

No ROS runtime anywhere here.
"""

from __future__ import annotations

from .driver import Progress, ReprocessReport, expand_bags, open_client, reprocess
from .reanalysis import BagOutcome, analysis_version, bag_fingerprint, bag_identity, reprocess_bag

__all__ = [
    "BagOutcome",
    "Progress",
    "ReprocessReport",
    "analysis_version",
    "bag_fingerprint",
    "bag_identity",
    "expand_bags",
    "open_client",
    "reprocess",
    "reprocess_bag",
]

"""A bag's re-analysis reads it once: one open of its storage, one parse of its metadata.yaml (issue 29, item 6)."""

from __future__ import annotations

import json

import pytest
import yaml
from rosbags.highlevel import AnyReader

from jointwear_ros.fleet import reprocess_bag
from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_fleet
from jointwear_ros.io.bags import LOST_KEY, bag_custom_data, bag_messages_lost, recorded_settings


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    specs = fleet_specs(1, 1, 1, rates=(1.5,), start_wear=15.0, method="joint")
    return write_fleet(tmp_path_factory.mktemp("one") / "bags", specs)[0]


def _counting(monkeypatch):
    """Count the opens of a bag's storage and the parses of a metadata.yaml text."""
    counts = {"opens": 0, "metadata_parses": 0}
    enter, load = AnyReader.__enter__, yaml.safe_load

    def counted_enter(self):
        counts["opens"] += 1
        return enter(self)

    def counted_load(stream, *a, **k):
        if isinstance(stream, str) and "rosbag2_bagfile_information" in stream:
            counts["metadata_parses"] += 1
        return load(stream, *a, **k)

    monkeypatch.setattr(AnyReader, "__enter__", counted_enter)
    monkeypatch.setattr(yaml, "safe_load", counted_load)
    return counts


def test_a_reanalysis_opens_the_bag_once_and_parses_its_metadata_once(bag, monkeypatch):
    plain = reprocess_bag(bag)  # the records without counting, to compare
    counts = _counting(monkeypatch)
    (bag / "metadata.yaml").write_text((bag / "metadata.yaml").read_text() + "\n")  # a text not seen before
    out = reprocess_bag(bag)
    assert out.ok, out.error
    assert counts == {"opens": 1, "metadata_parses": 1}
    assert out.records == plain.records and out.settings == plain.settings
    assert out.settings["robot"] == "robot_01"
    # outside a re-analysis the settings are read from the bag again (nothing is remembered across calls)
    assert recorded_settings(bag) == recorded_settings(bag)
    assert counts["opens"] == 3

    # the parse is remembered by the text: an edited metadata.yaml is parsed again, and no caller changes
    # another's copy
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    doc = yaml.safe_load(text)
    doc["rosbag2_bagfile_information"]["custom_data"] = {LOST_KEY: json.dumps({"/joint_states": 3})}
    try:
        meta.write_text(yaml.safe_dump(doc, sort_keys=False))
        assert bag_messages_lost(bag) == {"/joint_states": 3}
        bag_custom_data(bag)[LOST_KEY] = "changed"
        assert bag_custom_data(bag) == {LOST_KEY: json.dumps({"/joint_states": 3})}
    finally:
        meta.write_text(text)
    assert bag_messages_lost(bag) == {} and bag_custom_data(bag) == {}

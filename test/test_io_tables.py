"""Observation tables from and to files: CSV and rosbag2/MCAP round trips, every kind of bad
input named by file, column and row, and no half-written output on error."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from jointwear_ros.data import synth_observations
from jointwear_ros.errors import InputDataError
from jointwear_ros.io import tables
from jointwear_ros.io.tables import (
    DEFAULT_OBSERVATION_TOPIC,
    FRICTION_OBSERVATION_TYPE,
    read_bag,
    read_csv,
    read_table,
    write_bag,
    write_csv,
    write_table,
)
from jointwear_ros.io.typestore import jointwear_typestore
from jointwear_ros.types import ObservationTable

BAG_FIELDS = ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position")


@pytest.fixture(scope="module")
def table() -> ObservationTable:
    return synth_observations(n_cycles=4, effects=["lubrication"], seed=2)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# -- round trips ----------------------------------------------------------------
def test_csv_round_trip_keeps_every_column_exactly(table, tmp_path):
    out = write_csv(table, tmp_path / "obs.csv")
    back = read_table(out)
    assert back.names == table.names
    for name in table.names:
        np.testing.assert_array_equal(back[name], table[name])
    assert back.source == str(out)
    assert [p.name for p in tmp_path.iterdir()] == ["obs.csv"]  # no temporary files left


def test_bag_round_trip_with_rosbags(table, tmp_path):
    bag = write_bag(table, tmp_path / "obs_bag", joint_name="axis2")
    assert (bag / "metadata.yaml").is_file()
    for path in (bag, next(bag.glob("*.mcap"))):  # the bag directory or its .mcap file
        back = read_table(path)
        assert len(back) == len(table)
        assert set(back.names) == {"cycle", "time", *BAG_FIELDS}  # lube_hours is not a message field
        for name in ("cycle", *BAG_FIELDS):
            np.testing.assert_array_equal(back[name], table[name])
        np.testing.assert_allclose(back["time"], table["time"], atol=1e-9 * table["time"].max())


def test_bag_is_standard_mcap_readable_with_the_mcap_library(table, tmp_path):
    bag = write_bag(table, tmp_path / "obs_bag", joint_name="axis2")
    store = jointwear_typestore()
    rows = []
    with open(next(bag.glob("*.mcap")), "rb") as fh:
        reader = make_reader(fh)
        for schema, channel, message in reader.iter_messages():
            assert schema.name == FRICTION_OBSERVATION_TYPE
            assert schema.encoding == "ros2msg"
            assert channel.topic == DEFAULT_OBSERVATION_TOPIC
            assert channel.message_encoding == "cdr"
            msg = store.deserialize_cdr(message.data, FRICTION_OBSERVATION_TYPE)
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            assert message.log_time == stamp
            assert msg.joint_name == "axis2"
            rows.append([float(msg.cycle_id), *(float(getattr(msg, f)) for f in BAG_FIELDS)])
    expected = np.column_stack([table["cycle"], *(table[f] for f in BAG_FIELDS)])
    np.testing.assert_array_equal(np.array(rows), expected)


def test_bag_with_unknown_temperature_and_missing_fields_reads_back(tmp_path):
    v = np.array([5.0, 20.0, 50.0])
    t = ObservationTable({"speed": v, "tau_f": 0.05 + 1e-4 * v, "temperature": [40.0, math.nan, 41.0]})
    back = read_bag(write_table(t, tmp_path / "sparse"))
    assert math.isnan(back["temperature"][1]) and back["temperature"][2] == 41.0
    # fields absent from the table were written as NaN and are left out again
    assert "position" not in back and "tau_f_std" not in back
    np.testing.assert_array_equal(back["cycle"], 0.0)


def test_bag_topic_selection(table, tmp_path):
    bag = write_bag(table, tmp_path / "b", topic="/axis2/observations")
    assert len(read_bag(bag, topic="/axis2/observations")) == len(table)
    with pytest.raises(InputDataError, match=r"no jointwear_msgs/msg/FrictionObservation messages on topic '/other'.*"
                                             r"topics: /axis2/observations"):
        read_table(bag, topic="/other")


def test_csv_comments_text_columns_and_extra_numeric_columns(tmp_path):
    path = write(tmp_path / "obs.csv", "# exported from the observer\n# joint 2\n"
                                       "joint,speed,tau_f,hours_since_service\nA2,10,0.07,12\nA2,50,0.08,12.5\n")
    t = read_csv(path)
    assert t.names == ["speed", "tau_f", "hours_since_service"]  # the joint name column is text: ignored
    np.testing.assert_array_equal(t["hours_since_service"], [12.0, 12.5])


# -- bad input -------------------------------------------------------------------
@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("speed,load_torque\n10,0.1\n", "column 'tau_f' is missing (required); columns in the header: speed,"),
        ("tau_f\n0.1\n", "column 'speed' is missing (required)"),
        ("speed,tau_f\n10,0.1\n20,nan\n", "column 'tau_f', row 2 (line 3): 'nan' is not a finite number"),
        ("speed,tau_f\n10,0.1\n20,inf\n", "column 'tau_f', row 2 (line 3): 'inf' is not a finite number"),
        ("speed,tau_f,load_torque\n10,0.1,0.2\n20,0.1,0.3\n30,0.1,heavy\n",
         "column 'load_torque', row 3 (line 4): 'heavy' is not a number"),
        ("speed,tau_f,temperature\n10,0.1,40\n20,0.1,\n", "column 'temperature', row 2 (line 3): is empty"),
        ("speed,tau_f,position\n10,0.1,abc\n", "column 'position', row 1 (line 2): 'abc' is not a number"),
        ("", "the file is empty"),
        ("\n  \n", "the file is empty"),
        ("# only a comment\n", "no header line"),
        ("speed,tau_f\n", "no data rows after the header (line 1)"),
        ("speed,tau_f\n10,0.1,7\n", "row 1 (line 2) has 3 fields, the header has 2"),
        ("speed,tau_f,speed\n1,2,3\n", "column 'speed' appears twice in the header"),
        ("speed,,tau_f\n1,2,3\n", "column 2 of the header has no name"),
    ],
)
def test_bad_csv_gives_one_line_error_naming_file_column_and_row(tmp_path, content, message):
    path = write(tmp_path / "bad.csv", content)
    with pytest.raises(InputDataError) as exc:
        read_table(path)
    text = str(exc.value)
    assert "\n" not in text
    assert text.startswith(str(path) + ":")
    assert message in text


def test_binary_file_and_missing_paths_are_input_errors(tmp_path):
    binary = tmp_path / "obs.csv"
    binary.write_bytes(b"\xff\xfe\x00speed")
    with pytest.raises(InputDataError, match="not a UTF-8 text file"):
        read_table(binary)
    with pytest.raises(InputDataError, match="no such file or directory"):
        read_table(tmp_path / "nope.csv")
    (tmp_path / "somedir").mkdir()
    with pytest.raises(InputDataError, match="a directory without metadata.yaml is not a rosbag2 bag"):
        read_table(tmp_path / "somedir")


def test_corrupt_bag_is_an_input_error(table, tmp_path):
    bag = write_bag(table, tmp_path / "b")
    mcap = next(bag.glob("*.mcap"))
    mcap.write_bytes(mcap.read_bytes()[:200])
    with pytest.raises(InputDataError, match=r"cannot read the bag"):
        read_table(bag)


def test_non_finite_values_are_refused_on_write_and_named_on_read(tmp_path):
    with pytest.raises(InputDataError, match=r"column 'speed', row 2: inf is not finite"):
        write_bag(ObservationTable({"speed": [1.0, math.inf], "tau_f": [0.1, 0.1]}), tmp_path / "c")
    assert not (tmp_path / "c").exists()
    # an infinite optional field can be written (the message holds it) but not read back as data
    inf_plus = ObservationTable({"speed": [1.0, 2.0], "tau_f": [0.1, 0.1], "tau_plus": [0.2, math.inf]})
    bag = write_bag(inf_plus, tmp_path / "d")
    with pytest.raises(InputDataError, match=r"column 'tau_plus', row 2 \(message 2 on /jointwear/friction_obs"):
        read_bag(bag)


@pytest.mark.parametrize("cycle", [-1.0, 2.5, 2.0**33])
def test_bag_writer_rejects_cycle_ids_a_message_cannot_hold(tmp_path, cycle):
    t = ObservationTable({"speed": [1.0, 2.0], "tau_f": [0.1, 0.1], "cycle": [0.0, cycle]}, source="mine")
    with pytest.raises(InputDataError, match=r"mine: column 'cycle', row 2: .* is not a cycle id"):
        write_bag(t, tmp_path / "b")
    assert list(tmp_path.iterdir()) == []


def test_unknown_model_term_after_reading_is_a_model_error(table, tmp_path):
    from jointwear_ros.errors import ModelError
    from jointwear_ros.workbench import parse_spec

    read_table(write_csv(table, tmp_path / "obs.csv"))
    with pytest.raises(ModelError, match="unknown term 'lubrication_drag'"):
        parse_spec("paper + lubrication_drag")


# -- nothing half-written ----------------------------------------------------------
def test_failing_csv_write_leaves_no_file_and_keeps_the_old_one(table, tmp_path, monkeypatch):
    old = write_csv(table.select(np.arange(3)), tmp_path / "obs.csv")
    before = old.read_bytes()
    calls = {"n": 0}
    real = tables._fmt

    def failing(v: float) -> str:
        calls["n"] += 1
        if calls["n"] > 25:
            raise OSError("disk full")
        return real(v)

    monkeypatch.setattr(tables, "_fmt", failing)
    with pytest.raises(OSError, match="disk full"):
        write_csv(table, tmp_path / "obs.csv")
    with pytest.raises(OSError, match="disk full"):
        write_csv(table, tmp_path / "new.csv")
    assert calls["n"] > 25  # it failed part-way through the rows
    assert old.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["obs.csv"]


def test_failing_bag_write_leaves_nothing(table, tmp_path, monkeypatch):
    from rosbags.rosbag2 import Writer

    real = Writer.write
    calls = {"n": 0}

    def failing(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 5:
            raise OSError("disk full")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Writer, "write", failing)
    with pytest.raises(OSError, match="disk full"):
        write_bag(table, tmp_path / "bag")
    assert calls["n"] == 6
    assert list(tmp_path.iterdir()) == []


def test_bag_writer_refuses_to_overwrite(table, tmp_path):
    bag = write_bag(table, tmp_path / "bag")
    stamp = (bag / "metadata.yaml").read_bytes()
    with pytest.raises(InputDataError, match="already exists"):
        write_bag(table, bag)
    assert (bag / "metadata.yaml").read_bytes() == stamp

"""bag recover and the MCAP check, on bags the recorder's writer produced and then damaged on purpose.

Every message carries its index (``header.stamp.sec``) and an index-derived
payload, so a recovered bag is compared message by message with what was
written: nothing invented, nothing read from a corrupt chunk, nothing dropped
from an intact one.
"""

from __future__ import annotations

import hashlib
import json
import random
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from jointwear_ros.cli import main as cli_main
from jointwear_ros.errors import InputDataError
from jointwear_ros.io.bags import bag_info, read_messages
from jointwear_ros.io.mcap_bag import OPEN_KEY, McapBagWriter
from jointwear_ros.io.recover import check_bag, recover_bag, scan_mcap
from jointwear_ros.io.typestore import jointwear_typestore

JS = "sensor_msgs/msg/JointState"
T0 = 1_795_000_000_000_000_000


def _write_bag(path: Path, n: int, *, sync_every: int = 500, close: bool = True, compression: str = "zstd",
               chunk_size: int = 1 << 20) -> McapBagWriter:
    st = jointwear_typestore()
    w = McapBagWriter(path, compression=compression, chunk_size=chunk_size, fsync=False)
    msgdef, _ = st.generate_msgdef(JS, ros_version=2)
    cid = w.add_connection("/joint_states", JS, msgdef, rihs01=st.hash_rihs01(JS))
    cls, hdr, tm = st.types[JS], st.types["std_msgs/msg/Header"], st.types["builtin_interfaces/msg/Time"]
    for i in range(n):
        m = cls(header=hdr(stamp=tm(sec=i, nanosec=0), frame_id=""), name=[f"j{k}" for k in range(6)],
                position=np.arange(6.0) + 0.001 * i, velocity=np.full(6, 0.5), effort=np.full(6, 12.5 + 1e-4 * i))
        w.write(cid, T0 + i * 1_000_000, st.serialize_cdr(m, JS))
        if sync_every and i % sync_every == sync_every - 1:
            w.sync()
    if close:
        w.close()
    return w


def _indices(bag: Path) -> list[int]:
    out = []
    for m in read_messages(bag, topics=["/joint_states"]):
        i = int(m.msg.header.stamp.sec)
        # the payload is the one written for that index: not garbage that happened to parse
        assert m.msg.effort[0] == pytest.approx(12.5 + 1e-4 * i, abs=1e-12)
        assert m.log_time == T0 + i * 1_000_000
        out.append(i)
    return out


def _digest(d: Path) -> dict[str, str]:
    return {f.name: hashlib.sha256(f.read_bytes()).hexdigest() for f in sorted(d.iterdir())}


@pytest.fixture(scope="module")
def closed_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("src") / "bag"
    _write_bag(bag, 20000)
    return bag


def test_the_writer_produces_a_checked_bag_that_rosbags_and_mcap_read_completely(closed_bag):
    (scan,) = check_bag(closed_bag)
    assert scan.complete and scan.data_crc == "ok" and scan.summary_crc == "ok" and scan.problems == []
    assert scan.chunks_without_crc == 0
    assert bag_info(closed_bag).check == [{"file": "bag.mcap", "chunks": 40, "chunks_without_crc": 0,
                                           "data_crc": "ok", "summary_crc": "ok"}]
    assert scan.chunks == 40 and scan.messages == 20000  # one chunk per sync of 500
    meta = yaml.safe_load((closed_bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["message_count"] == 20000 and meta["custom_data"] is None
    assert _indices(closed_bag) == list(range(20000))
    from mcap.reader import make_reader

    with (closed_bag / "bag.mcap").open("rb") as fh:
        reader = make_reader(fh)
        assert reader.get_summary().statistics.message_count == 20000
        assert sum(1 for _ in reader.iter_messages()) == 20000


def test_a_changed_byte_in_the_summary_is_reported_and_recover_does_not_need_the_summary(closed_bag, tmp_path):
    bag = tmp_path / "summary"
    shutil.copytree(closed_bag, bag)
    f = bag / "bag.mcap"
    data = bytearray(f.read_bytes())
    data[len(data) - 37 - 10] ^= 0xFF  # inside the last summary-offset record, before the footer
    f.write_bytes(bytes(data))
    with pytest.raises(InputDataError, match=r"bag\.mcap: damaged at byte \d+: summary section CRC mismatch"):
        check_bag(bag)
    rep = recover_bag(bag, tmp_path / "summary_rec")
    assert rep.messages == 20000 and rep.data_crc == "ok" and rep.skipped_chunks == [] and rep.damaged == []


def test_an_open_bag_says_so_in_its_metadata_and_is_refused_by_bag_info(tmp_path, capsys):
    bag = tmp_path / "open"
    w = _write_bag(bag, 1200, close=False)
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["custom_data"] == {OPEN_KEY: "open"}
    assert meta["message_count"] == 1000 == w.synced_count  # what was synced, not what is buffered
    assert cli_main(["bag", "info", str(bag)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"open.mcap: unfinished at byte {(bag / 'open.mcap').stat().st_size}: no footer" in err
    assert "still being recorded, or the recorder was killed" in err and f"jointwear bag recover {bag}" in err
    w.close()
    assert cli_main(["bag", "info", str(bag)]) == 0


def test_bag_info_and_replay_refuse_a_bag_with_20_kb_zeroed_in_the_middle(closed_bag, tmp_path, capsys):
    bag = tmp_path / "zeroed"
    shutil.copytree(closed_bag, bag)
    f = bag / "bag.mcap"
    data = bytearray(f.read_bytes())
    mid = len(data) // 2
    data[mid:mid + 20_000] = bytes(20_000)
    f.write_bytes(bytes(data))
    capsys.readouterr()
    assert cli_main(["bag", "info", str(closed_bag)]) == 0  # the intact copy passes
    capsys.readouterr()
    assert cli_main(["bag", "info", str(bag)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"jointwear: error: {f}: damaged at byte ")
    offset = int(err.split("damaged at byte ")[1].split(":")[0])
    assert mid - (1 << 20) <= offset <= mid + 20_000  # at the damage (the chunk holding its start)
    assert f"jointwear bag recover {bag}" in err
    for replay in (["replay", str(bag)], ["replay", str(bag), "--publish"]):
        assert cli_main(replay) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and f"{f}: damaged at byte {offset}" in err

    out = tmp_path / "zeroed_rec"
    before = _digest(bag)
    assert cli_main(["bag", "recover", str(bag), "--out", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert _digest(bag) == before  # the input is never modified
    got = _indices(out)
    assert rep["messages"] == len(got) == bag_info(out).message_count
    assert got == sorted(set(got))
    missing = sorted(set(range(20000)) - set(got))
    # what is missing is exactly the messages of the chunks the damage touched, reported as such
    assert rep["skipped_chunks"] or rep["damaged"]
    assert 0 < len(missing) <= 1500 and missing == list(range(missing[0], missing[-1] + 1))
    assert rep["data_crc"] == "mismatch" and rep["truncated_bytes"] == 0 and rep["source_complete"]
    assert cli_main(["bag", "info", str(out)]) == 0  # the rebuilt bag passes the check


def test_a_chunk_failing_its_crc_is_skipped_and_reported_never_read_as_valid(tmp_path, capsys):
    bag = tmp_path / "flip"
    _write_bag(bag, 3000, compression="none")  # uncompressed: only the CRC can notice a changed byte
    f = bag / "flip.mcap"
    scan = scan_mcap(f)
    assert scan.chunks == 6 and scan.problems == []
    data = bytearray(f.read_bytes())
    # the 3rd chunk (messages 1000..1499): change one byte of one message's effort payload
    offsets = []
    pos = 8
    while pos < len(data) and len(offsets) < 3:
        op, length = data[pos], int.from_bytes(data[pos + 1:pos + 9], "little")
        if op == 0x06:
            offsets.append(pos)
        pos += 9 + length
    data[offsets[2] + 4000] ^= 0x01
    f.write_bytes(bytes(data))
    with pytest.raises(InputDataError, match=r"flip\.mcap: damaged at byte \d+: chunk of \d+ bytes fails its CRC"):
        check_bag(bag)
    rep = recover_bag(bag, tmp_path / "flip_rec")
    assert [c["offset"] for c in rep.skipped_chunks] == [offsets[2]]
    assert "fails its CRC" in rep.skipped_chunks[0]["reason"]
    assert _indices(tmp_path / "flip_rec") == list(range(1000)) + list(range(1500, 3000))
    assert rep.messages == 2500 and rep.topics == {"/joint_states": {"type": JS, "count": 2500}}


def test_recover_of_a_file_cut_anywhere_gives_exactly_the_complete_chunks_before_the_cut(tmp_path):
    _write_bag(tmp_path / "whole", 5000)
    data = (tmp_path / "whole" / "whole.mcap").read_bytes()
    chunk_ends = []  # end offset of each chunk record, in order (500 messages each)
    pos = 8
    while pos < len(data):
        op, length = data[pos], int.from_bytes(data[pos + 1:pos + 9], "little")
        pos += 9 + length
        if op == 0x06:
            chunk_ends.append(pos)
    rng = random.Random(7)
    cuts = [0, 5, 8, 30, chunk_ends[3], chunk_ends[3] + 1, len(data) - 1] + [rng.randrange(9, len(data)) for _ in range(8)]
    for k, cut in enumerate(cuts):
        src = tmp_path / f"cut{k}"
        src.mkdir()
        (src / "cut.mcap").write_bytes(data[:cut])  # no metadata.yaml: a recorder killed early
        rep = recover_bag(src, tmp_path / f"cut{k}_rec")
        got = _indices(tmp_path / f"cut{k}_rec")
        # every chunk that was completely on disk, in order, nothing after the cut
        assert got == list(range(500 * sum(e <= cut for e in chunk_ends))), cut
        assert rep.messages == len(got) and not rep.source_complete
        assert rep.skipped_chunks == [] and rep.damaged == [] and rep.source_metadata == "missing"
        assert bag_info(tmp_path / f"cut{k}_rec").message_count == len(got)


def test_recover_counts_a_zero_byte_file_as_an_empty_bag_and_keeps_the_lost_message_notes(tmp_path):
    src = tmp_path / "zero"
    src.mkdir()
    (src / "zero.mcap").write_bytes(b"")
    rep = recover_bag(src, tmp_path / "zero_rec")
    assert rep.messages == 0 and rep.topics == {} and rep.truncated_bytes == 0
    assert bag_info(tmp_path / "zero_rec").message_count == 0

    bag = tmp_path / "lostnote"
    w = _write_bag(bag, 700, close=False)
    w.custom_data["jointwear.messages_lost"] = json.dumps({"/joint_states": 12})
    w.sync()
    rep = recover_bag(bag, tmp_path / "lostnote_rec")
    assert rep.messages == 700 and rep.source_metadata == "read"
    info = bag_info(tmp_path / "lostnote_rec")
    assert info.messages_lost == {"/joint_states": 12}  # the recorder's note survives recovery
    meta = yaml.safe_load((tmp_path / "lostnote_rec" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert OPEN_KEY not in meta["custom_data"] and "jointwear.recovered" in meta["custom_data"]


def test_recover_refuses_an_existing_out_and_a_missing_source_with_exit_2_and_writes_nothing(closed_bag, tmp_path,
                                                                                             capsys):
    out = tmp_path / "exists"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert cli_main(["bag", "recover", str(closed_bag), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "already exists" in err
    assert [p.name for p in out.iterdir()] == ["keep.txt"]
    assert cli_main(["bag", "recover", str(tmp_path / "nope"), "--out", str(tmp_path / "o")]) == 2
    assert "no such bag" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cli_main(["bag", "recover", str(empty), "--out", str(tmp_path / "o")]) == 2
    assert "no .mcap file" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty", "exists"]


def test_a_bag_directory_without_metadata_points_to_recover(tmp_path, closed_bag, capsys):
    bag = tmp_path / "nometa"
    bag.mkdir()
    shutil.copy(closed_bag / "bag.mcap", bag / "bag.mcap")
    assert cli_main(["bag", "info", str(bag)]) == 2
    err = capsys.readouterr().err
    assert "no metadata.yaml" in err and f"jointwear bag recover {bag}" in err
    assert cli_main(["bag", "recover", str(bag), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["bag"] == str(tmp_path / "nometa_recovered") and rep["messages"] == 20000
    assert rep["source_complete"] and rep["data_crc"] == "ok" and rep["skipped_chunks"] == []


def test_random_damage_never_yields_an_invented_or_altered_message(tmp_path):
    """Seeded random damage (zeros, random bytes, a cut) anywhere in a bag: recover never fails with
    anything but its own error, and every message it returns is one that was written, value for value,
    in order; the check always reports the damage."""
    src = tmp_path / "src"
    _write_bag(src, 1500, sync_every=150)
    data = (src / "src.mcap").read_bytes()
    rng = random.Random(2026)
    for k in range(40):
        bad = bytearray(data)
        start = rng.randrange(0, len(bad))
        length = rng.choice([1, 7, 100, 2000, 20000])
        kind = rng.choice(["zeros", "random", "cut"])
        if kind == "zeros":
            bad[start:start + length] = bytes(len(bad[start:start + length]))
        elif kind == "random":
            bad[start:start + length] = rng.randbytes(len(bad[start:start + length]))
        else:
            del bad[start:]
        if bytes(bad) == data:
            continue
        d = tmp_path / f"d{k}"
        d.mkdir()
        (d / "d.mcap").write_bytes(bytes(bad))
        with pytest.raises(InputDataError, match=r"d\.mcap: (damaged|unfinished) at byte \d+"):
            check_bag(d)
        rep = recover_bag(d, tmp_path / f"d{k}_rec")
        got = _indices(tmp_path / f"d{k}_rec")  # checks each payload against its index
        assert got == sorted(set(got)) and rep.messages == len(got) <= 1500, (k, kind, start, length)
        if start > len(data) // 2:  # damage in the second half spares the first chunk
            assert got[:150] == list(range(150)), (k, kind, start, length)

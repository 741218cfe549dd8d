"""Bags that are not what they claim (issue 28, item 5): `bag recover` of a non-bag refuses in one line and writes
nothing; a metadata.yaml with a value of the wrong type (a number where a list belongs) is one line naming the file
and the key, exit 2, on every reader, and `bag recover` still rebuilds the bag from its MCAP."""

from __future__ import annotations

import copy
import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.cli import main as cli_main
from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_fleet
from jointwear_ros.io.bags import metadata_problem

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("faults28")
    return write_fleet(root / "archive", fleet_specs(1, 1, 1, rates=(0.0,), start_wear=15.0, method="joint"))[0]


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


@pytest.mark.parametrize("name, content", [
    ("notes.txt", b"maintenance notes\n"),   # a text file
    ("empty.txt", b""),                      # an empty file that is not named as a recording
    ("fake.mcap", b"not an mcap at all"),    # named .mcap, but no MCAP magic
    ("folder", None),                        # a directory whose only .mcap is not MCAP
])
def test_recover_of_a_non_bag_is_one_line_exit_2_and_writes_nothing(name, content, tmp_path, monkeypatch, capsys):
    work = tmp_path / "work"
    work.mkdir()
    if content is None:
        (work / name).mkdir()
        (work / name / "a.mcap").write_bytes(b"x" * 100)
    else:
        (work / name).write_bytes(content)
    monkeypatch.chdir(work)  # the default --out is "<bag>_recovered" beside the bag: here, beside `work`
    before = _tree(tmp_path)
    assert cli_main(["bag", "recover", name]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"jointwear: error: {name}: not ") and "nothing written" in err[0]
    assert _tree(tmp_path) == before


def _with_metadata(bag: Path, dst: Path, info: dict[str, Any] | Any) -> Path:
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(bag, dst)
    (dst / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}))
    return dst


def _info(bag: Path) -> dict[str, Any]:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


@pytest.mark.parametrize("key", ["topics_with_message_count", "relative_file_paths", "files"])
def test_a_number_where_a_list_belongs_is_one_line_naming_the_file_and_the_key(key, bag, tmp_path, capsys):
    info = _info(bag)
    info[key] = 5
    broken = _with_metadata(bag, tmp_path / "broken", info)
    for cmd in (["bag", "info", str(broken)], ["replay", str(broken)], ["history", "import", str(broken), "--db",
                                                                         str(tmp_path / "h.db"), "--reestimate"]):
        assert cli_main(cmd) == 2, cmd
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "internal error" not in err[0], (cmd, err)
        assert f"{broken / 'metadata.yaml'}: key '{key}' is a number where a list belongs" in err[0], (cmd, err)
    # recover rebuilds the metadata from the MCAP: that is what the message offers
    assert cli_main(["bag", "recover", str(broken), "--out", str(tmp_path / "mended"), "--json"]) == 0
    capsys.readouterr()
    assert cli_main(["bag", "info", str(tmp_path / "mended"), "--json"]) == 0
    assert '"message_count": 1707' in capsys.readouterr().out


def _key_paths(d: Any, pre: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = []
    if isinstance(d, dict):
        for k, v in d.items():
            out.append((*pre, k))
            out += _key_paths(v, (*pre, k))
    elif isinstance(d, list) and d:
        out.append((*pre, len(d) - 1))
        out += _key_paths(d[-1], (*pre, len(d) - 1))
    return out


DELETE = object()
VALUES = st.one_of(st.integers(-3, 10**12), st.floats(allow_nan=True), st.text(max_size=5), st.booleans(), st.none(),
                   st.lists(st.integers(0, 9), max_size=2), st.dictionaries(st.text(max_size=3), st.integers(),
                                                                         max_size=2), st.just(DELETE))


def _label(path: tuple[Any, ...]) -> str:
    return "".join(f"[{p}]" if isinstance(p, int) else (f".{p}" if i else str(p)) for i, p in enumerate(path))


@SETTINGS
@given(data=st.data())
def test_metadata_of_any_type_in_any_key_is_read_or_refused_in_one_line_naming_the_key(data, bag, tmp_path,
                                                                                         capsys):
    good = _info(bag)
    paths = _key_paths(good)
    path = data.draw(st.sampled_from(paths), label="key")
    value = data.draw(VALUES, label="value")
    info = copy.deepcopy(good)
    holder = info
    for p in path[:-1]:
        holder = holder[p]
    if value is DELETE:
        del holder[path[-1]]
    else:
        holder[path[-1]] = value
    problem = metadata_problem(info)
    if problem:  # the problem named is the key changed (or, for a removed key, the key missing)
        assert f"'{_label(path)}'" in problem, (path, value, problem)
    broken = _with_metadata(bag, tmp_path / "fuzzed", info)
    rc = cli_main(["bag", "info", str(broken)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc in (0, 2) and len(err) <= 1 and not any("internal error" in e for e in err), (path, value, err)
    if problem:
        assert rc == 2 and err == [f"jointwear: error: {broken / 'metadata.yaml'}: {problem}; `jointwear bag "
                                   f"recover {broken}` rebuilds it from the .mcap"]
    shutil.rmtree(tmp_path / "re", ignore_errors=True)
    assert cli_main(["bag", "recover", str(broken), "--out", str(tmp_path / "re"), "--json"]) == 0, (path, value)
    capsys.readouterr()

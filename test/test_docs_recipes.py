"""docs/extending.md section 8: each recipe for changing jointwear itself touches the files it states.

Each ``###`` recipe of the section is applied to a copy of the checkout (the package, its config,
message definitions and ``package.xml``): a block whose first line is ``# PATH, insert before: LINE``
is inserted before the first line of PATH that starts with LINE (the line must exist, once at least);
``# PATH, new file`` writes a file. The recipe's new test files then run in the changed copy (they
must pass) and in an unchanged copy (they must fail: a recipe's test tests its addition). The number
of files the blocks touch must be the recipe's ``**Files touched: N**``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "extending.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```$", re.S | re.M)
INSERT = re.compile(r"#\s*(\S+),\s*insert before:\s?(.*)")
NEW_FILE = re.compile(r"#\s*(\S+),\s*new file")
TOUCHED = re.compile(r"\*\*Files touched: (\d+)\*\*")
COPIED = ("jointwear_ros", "config", "msg_defs", "package.xml", "setup.cfg")


@dataclass(frozen=True)
class Edit:
    path: str
    anchor: str | None  # None: a new file
    text: str
    line: int  # in docs/extending.md


@dataclass(frozen=True)
class Recipe:
    title: str
    touched: int
    edits: tuple[Edit, ...]

    @property
    def files(self) -> set[str]:
        return {e.path for e in self.edits}

    @property
    def tests(self) -> list[str]:
        return sorted(e.path for e in self.edits if e.anchor is None and Path(e.path).name.startswith("test_"))


def parse_recipes(text: str) -> list[Recipe]:
    """The ``###`` recipes of section 8 of ``text`` (docs/extending.md)."""
    start = text.index("\n## 8.")
    end = text.find("\n## ", start + 1)
    section = text[start: end if end > 0 else len(text)]
    offset = text.count("\n", 0, start)
    out = []
    for part in re.split(r"(?m)^(?=### )", section)[1:]:
        title = part.splitlines()[0].lstrip("# ").strip()
        m = TOUCHED.search(part)
        assert m, f"recipe {title!r} does not say **Files touched: N**"
        edits = []
        part_line = offset + section.count("\n", 0, section.index(part))
        for f in FENCE.finditer(part):
            if f.group(1) != "python":
                continue
            first, _, body = f.group(2).partition("\n")
            line = part_line + part.count("\n", 0, f.start(2)) + 1
            if (ins := INSERT.fullmatch(first.strip())) is not None:
                anchor = re.match(r"#\s*\S+,\s*insert before: ?(.*)", first).group(1)  # keep the anchor's indentation
                edits.append(Edit(ins.group(1), anchor, body, line))
            elif (new := NEW_FILE.fullmatch(first.strip())) is not None:
                edits.append(Edit(new.group(1), None, body, line))
        out.append(Recipe(title, int(m.group(1)), tuple(edits)))
    return out


def apply(recipe: Recipe, root: Path) -> None:
    """Apply ``recipe``'s edits to the checkout copy at ``root``."""
    for e in recipe.edits:
        target = root / e.path
        if e.anchor is None:
            assert not target.exists(), f"docs/extending.md:{e.line}: {e.path} is said to be new but exists"
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(e.text, encoding="utf-8")
            continue
        lines = target.read_text(encoding="utf-8").splitlines(keepends=True)
        at = next((i for i, line in enumerate(lines) if line.startswith(e.anchor)), None)
        assert at is not None, f"docs/extending.md:{e.line}: no line of {e.path} starts with {e.anchor!r}"
        lines[at:at] = [e.text]
        target.write_text("".join(lines), encoding="utf-8")


RECIPES = parse_recipes(GUIDE.read_text(encoding="utf-8"))


def _copy(dest: Path) -> Path:
    dest.mkdir(parents=True)
    for name in COPIED:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(src, dest / name)
    (dest / "test").mkdir()
    return dest


def _pytest(root: Path, tests: list[str]) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(root), PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                           "--noconftest", *tests], cwd=root, env=env, capture_output=True, text=True, timeout=600)


def test_section_8_has_the_three_recipes_the_issue_asks_for():
    titles = [r.title for r in RECIPES]
    assert len(RECIPES) == 3 and all(r.tests for r in RECIPES), titles
    assert {"cycle setting", "friction term", "history backend"} == {
        k for k in ("cycle setting", "friction term", "history backend") for t in titles if k in t}


@pytest.mark.slow
@pytest.mark.parametrize("recipe", RECIPES, ids=[r.title for r in RECIPES])
def test_the_recipe_touches_the_files_it_states_and_its_tests_pass_only_with_it(recipe, tmp_path):
    assert len(recipe.files) == recipe.touched, (
        f"{recipe.title}: says {recipe.touched} files, its blocks touch {sorted(recipe.files)}")
    changed = _copy(tmp_path / "changed")
    apply(recipe, changed)
    r = _pytest(changed, recipe.tests)
    assert r.returncode == 0, f"{recipe.title}: its tests fail with the recipe applied:\n{r.stdout[-4000:]}\n{r.stderr[-2000:]}"
    unchanged = _copy(tmp_path / "unchanged")
    for e in recipe.edits:
        if e.anchor is None:
            (unchanged / e.path).parent.mkdir(parents=True, exist_ok=True)
            (unchanged / e.path).write_text(e.text, encoding="utf-8")
    r = _pytest(unchanged, recipe.tests)
    assert r.returncode != 0, f"{recipe.title}: its tests pass without the recipe, so they do not test it"


def test_the_recipe_reader_inserts_before_the_anchor_and_refuses_a_missing_one(tmp_path):
    text = ("intro\n## 8. x\n\n### a\n\n**Files touched: 2**\n\n```python\n# pkg/m.py, insert before:     def g():\n"
            "    y = 1\n\n```\n\n```python\n# test/test_m.py, new file\nX = 1\n```\n")
    (recipe,) = parse_recipes(text)
    assert recipe.touched == 2 and recipe.files == {"pkg/m.py", "test/test_m.py"} and recipe.tests == ["test/test_m.py"]
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "m.py").write_text("class A:\n    def f():\n        pass\n    def g():\n        pass\n")
    apply(recipe, tmp_path)
    assert (tmp_path / "pkg" / "m.py").read_text().splitlines()[3:5] == ["    y = 1", ""]
    assert (tmp_path / "test" / "test_m.py").read_text() == "X = 1\n"
    bad = Recipe("b", 1, (Edit("pkg/m.py", "    def nowhere", "z = 2\n", 1),))
    with pytest.raises(AssertionError, match="no line of pkg/m.py starts with"):
        apply(bad, tmp_path)

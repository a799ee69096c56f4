"""tools/loc_report.py: which lines count as code, which package a file counts for, revisions."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

REPO = Path(__file__).resolve().parents[2]


def _load() -> ModuleType:
    spec = importlib.util.spec_from_file_location("loc_report", REPO / "tools" / "loc_report.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


loc = _load()

SOURCE = '''"""A module docstring
on two lines."""

# a comment
import math  # a trailing comment is code


def f(x):
    """Docstring."""
    s = """a string
that is data"""
    return math.sqrt(x) + len(s)
'''


def test_lines_are_code_docstring_comment_or_blank() -> None:
    c = loc.count_source(SOURCE)
    assert (c.files, c.code, c.docstring, c.comment, c.blank) == (1, 5, 3, 1, 3)
    assert c.code + c.docstring + c.comment + c.blank == len(SOURCE.splitlines())
    with pytest.raises(loc.LocError, match=r"bad.py: not valid Python"):
        loc.count_source("def (:\n", "bad.py")


def test_files_count_for_their_package_and_tests_for_the_package_they_mirror() -> None:
    assert loc.group_of("robot_daemon/sim/world.py") == ("product", "robot_daemon")
    assert loc.group_of("tools/loc_report.py") == ("support", "tools")
    assert loc.group_of("tests/interbot_core/test_rooms.py") == ("tests", "interbot_core")
    assert loc.group_of("tests/test_architecture.py") == ("tests", "(top level)")
    assert loc.group_of("README.md") is None and loc.group_of("setup.py") is None
    assert loc.group_of(".venv/lib/x.py") is None


def test_a_revision_is_read_from_git_and_compared(tmp_path: Path) -> None:
    def git(*args: str) -> None:
        subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True)

    (tmp_path / "interbot_core").mkdir()
    (tmp_path / "interbot_core" / "a.py").write_text("x = 1\ny = 2\n", encoding="utf-8")
    git("init", "-q")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "one")
    (tmp_path / "interbot_core" / "a.py").write_text("x = 1\n", encoding="utf-8")
    before = loc.build_report("before", loc.sources_at("HEAD", tmp_path))
    after = loc.build_report("after", loc.sources_at(None, tmp_path))
    assert before.groups[("product", "interbot_core")].code == 2
    assert after.groups[("product", "interbot_core")].code == 1
    table = loc.render([before, after])
    assert "| interbot_core | 2 (1) | 1 (1) | -1 |" in table
    with pytest.raises(loc.LocError, match="no-such-rev"):
        list(loc.sources_at("no-such-rev", tmp_path))

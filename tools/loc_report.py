"""Lines of code per package, product and tests counted apart (issue 13: "lines of code should
go down: report the count per package before and after").

    python tools/loc_report.py                 # the working tree (tracked + untracked files)
    python tools/loc_report.py --rev main      # any git revision, read with `git show`
    python tools/loc_report.py --rev A --rev B # two revisions side by side, with the change
    python tools/loc_report.py --json          # machine-readable

A Python line is one of (first match wins):

- *blank*: only whitespace;
- *docstring*: inside a string literal that is a statement of its own (module, class and function
  docstrings, and the odd bare string used as a comment);
- *comment*: only a ``#`` comment;
- *code*: everything else — the figure the report is about.

A package is a top-level folder (``robot_daemon``, ``bench``, ``tools`` …); a test file counts for
the package its ``tests/<package>/`` folder mirrors, and ``tests/e2e``, ``tests/faults`` and the
files at the top of ``tests/`` count under their own names. Only ``*.py`` files are read.
"""

from __future__ import annotations

import argparse
import ast
import io
import json
import subprocess
import sys
import tokenize
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

PRODUCT = (
    "interbot_core",
    "interbot_link",
    "interbot_qt",
    "interbot_cli",
    "robot_daemon",
    "base_station_app",
    "tablet_app",
)
# Not installed on a robot, a station or a tablet: benchmarks and developer tools.
SUPPORT = ("bench", "tools")
SKIPPED_DIRS = {".venv", ".git", "build", "dist", "__pycache__", ".mypy_cache", ".ruff_cache"}


class LocError(Exception):
    """A revision could not be read or a file could not be counted."""


@dataclass
class Count:
    """Line counts of one file or one group of files."""

    files: int = 0
    code: int = 0
    docstring: int = 0
    comment: int = 0
    blank: int = 0

    def add(self, other: Count) -> None:
        self.files += other.files
        self.code += other.code
        self.docstring += other.docstring
        self.comment += other.comment
        self.blank += other.blank


def count_source(text: str, name: str = "<string>") -> Count:
    """Classify every line of one Python source (see the module docstring for the rules)."""
    lines = text.splitlines()
    kinds = ["blank" if not line.strip() else "" for line in lines]
    try:
        tree = ast.parse(text, filename=name)
    except SyntaxError as exc:
        raise LocError(f"{name}: not valid Python ({exc.msg}, line {exc.lineno})") from exc
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Expr)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)
        ):
            end = node.end_lineno if node.end_lineno is not None else node.lineno
            for lineno in range(node.lineno, end + 1):
                if not kinds[lineno - 1]:
                    kinds[lineno - 1] = "docstring"
    code_lines: set[int] = set()
    ignorable = {
        tokenize.COMMENT,
        tokenize.NL,
        tokenize.NEWLINE,
        tokenize.INDENT,
        tokenize.DEDENT,
        tokenize.ENDMARKER,
    }
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type not in ignorable:
            code_lines.update(range(tok.start[0], tok.end[0] + 1))
    count = Count(files=1)
    for lineno, kind in enumerate(kinds, start=1):
        if not kind:
            kind = "code" if lineno in code_lines else "comment"
        setattr(count, kind, getattr(count, kind) + 1)
    return count


def group_of(path: str) -> tuple[str, str] | None:
    """``(section, group)`` of a repository path: section is product, support or tests."""
    parts = Path(path).parts
    if not parts or not path.endswith(".py") or SKIPPED_DIRS & set(parts):
        return None
    top = parts[0]
    if top in PRODUCT:
        return ("product", top)
    if top in SUPPORT:
        return ("support", top)
    if top == "tests":
        return ("tests", parts[1] if len(parts) > 2 else "(top level)")
    return None


def _git(args: list[str], cwd: Path) -> bytes:
    result = subprocess.run(["git", *args], cwd=cwd, capture_output=True, check=False)
    if result.returncode != 0:
        raise LocError(f"git {' '.join(args)}: {result.stderr.decode(errors='replace').strip()}")
    return result.stdout


def sources_at(rev: str | None, repo: Path = REPO) -> Iterable[tuple[str, str]]:
    """``(path, text)`` of every Python file at a git revision, or in the working tree."""
    if rev is None:
        listed = _git(["ls-files", "--cached", "--others", "--exclude-standard"], repo)
        for path in sorted(set(listed.decode().splitlines())):
            file = repo / path
            if path.endswith(".py") and file.is_file():
                yield path, file.read_text(encoding="utf-8")
        return
    listed = _git(["ls-tree", "-r", "--name-only", rev], repo)
    for path in listed.decode().splitlines():
        if path.endswith(".py"):
            yield path, _git(["show", f"{rev}:{path}"], repo).decode("utf-8")


@dataclass
class Report:
    """Counts per ``(section, group)``."""

    label: str
    groups: dict[tuple[str, str], Count] = field(default_factory=dict)

    def section_total(self, section: str) -> Count:
        total = Count()
        for (sec, _), count in self.groups.items():
            if sec == section:
                total.add(count)
        return total


def build_report(label: str, sources: Iterable[tuple[str, str]]) -> Report:
    report = Report(label)
    for path, text in sources:
        key = group_of(path)
        if key is not None:
            report.groups.setdefault(key, Count()).add(count_source(text, path))
    return report


SECTIONS = (
    ("product", "Product packages"),
    ("support", "Benchmarks and tools"),
    ("tests", "Tests"),
)


def render(reports: list[Report]) -> str:
    """A Markdown table per section: code lines (files) per revision, and the change."""
    out: list[str] = []
    two = len(reports) == 2
    for section, title in SECTIONS:
        keys = sorted({k for r in reports for k in r.groups if k[0] == section})
        if not keys:
            continue
        head = ["package", *(f"{r.label}: code (files)" for r in reports)]
        if two:
            head.append("change")
        out.append(f"### {title}\n")
        out.append("| " + " | ".join(head) + " |")
        out.append("|" + "---|" * len(head))
        rows = [(key[1], [r.groups.get(key, Count()) for r in reports]) for key in keys]
        rows.append(("**total**", [r.section_total(section) for r in reports]))
        for name, counts in rows:
            cells = [name, *(f"{c.code} ({c.files})" for c in counts)]
            if two:
                cells.append(f"{counts[1].code - counts[0].code:+d}")
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out)


def as_json(reports: list[Report]) -> str:
    return json.dumps(
        {
            r.label: {f"{sec}/{grp}": vars(c) for (sec, grp), c in sorted(r.groups.items())}
            for r in reports
        },
        indent=2,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rev",
        action="append",
        default=[],
        help="git revision to count (repeatable); default: the working tree",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    args = parser.parse_args(argv)
    try:
        revs: list[str | None] = list(args.rev) or [None]
        reports = [build_report(rev or "working tree", sources_at(rev)) for rev in revs]
    except LocError as exc:
        print(f"loc_report: {exc}", file=sys.stderr)
        return 2
    print(as_json(reports) if args.json else render(reports))
    return 0


if __name__ == "__main__":
    sys.exit(main())

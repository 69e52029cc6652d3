"""docs/reliability.md names the test that holds each promise: every name it gives is a
test that exists (issue 37: "docs/reliability.md lists each promise and its test").

A name is written `test_file.py::test_function`, or `::test_function` for a function of the
test file named last before it (as the page is read); `test_prefix_*` stands for the
functions that start with the prefix, at least one."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).parent.parent
PAGE = ROOT / "docs" / "reliability.md"
#: A test file's name, or `::name` (a function of the file named last).
NAME = re.compile(r"(test_\w+\.py)|::(test_\w+\*?)")


def functions(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {node.name for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))}


def named_tests(text: str) -> list[tuple[str | None, str]]:
    """(file, function) for every `::function` of ``text``, with the file named last."""
    found, last = [], None
    for match in NAME.finditer(text):
        if match.group(1):
            last = match.group(1)
        else:
            found.append((last, match.group(2)))
    return found


def test_every_test_the_page_names_exists():
    text = PAGE.read_text(encoding="utf-8")
    names = named_tests(text)
    assert len(names) > 120  # the page names its tests (137 on 2026-12-07)
    missing = []
    for file, function in names:
        path = ROOT / "tests" / file if file else None
        if path is None or not path.is_file():
            missing.append(f"{file}::{function} (no such file)")
            continue
        defined = functions(path)
        if function.endswith("*"):
            ok = any(name.startswith(function[:-1]) for name in defined)
        else:
            ok = function in defined
        if not ok:
            missing.append(f"{file}::{function}")
    assert not missing, missing
    for file in set(re.findall(r"(test_\w+\.py)", text)):
        assert (ROOT / "tests" / file).is_file(), file


def test_the_third_pass_lists_every_item_and_line():
    """The issue-37 section has items 1 to 7, each naming a test, and the six lines it had
    to make true."""
    text = PAGE.read_text(encoding="utf-8")
    section = text.split("## The third hardening pass (issue 37)")[1].split("\n## ")[0]
    items = re.split(r"\n(?=\d\. \*)", section)
    numbered = [item for item in items if re.match(r"\d\. \*", item)]
    assert [item[0] for item in numbered] == list("1234567")
    for item in numbered:
        assert named_tests(item), item[:60]
    lines = section.split("The lines it had to make true:")[1]
    assert lines.count("\n- *") == 6


def test_a_missing_name_is_found():
    """The check itself: a name that is no test is reported."""
    names = named_tests("`test_reliability_doc.py::test_no_such_thing` and "
                        "`::test_every_test_the_page_names_exists`")
    defined = functions(Path(__file__))
    assert [(f, n in defined) for f, n in names] == [
        ("test_reliability_doc.py", False), ("test_reliability_doc.py", True)]

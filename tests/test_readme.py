"""README.md stays true to the package (issue 36): its list of shipped scenes is the list
`rodsim scenes` prints, and the example files its commands name are shipped."""

from __future__ import annotations

import re
from pathlib import Path

from rodsim.core.scene import scene_paths

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def test_the_readme_lists_every_shipped_scene_and_no_other(cli, capsys):
    start = README.index("Shipped scenes (`rodsim scenes`")
    end = README.index("A name that is neither a shipped scene nor a file", start)
    listed = {name for name in re.findall(r"`([a-z0-9][a-z0-9-]*)`", README[start:end])
              if name != "reach"}
    assert cli(["scenes"]) == 0
    printed = {line.split()[0] for line in capsys.readouterr().out.splitlines() if line}
    assert printed == set(scene_paths())
    assert listed == printed, (f"missing from README: {sorted(printed - listed)}; "
                               f"not shipped: {sorted(listed - printed)}")


def test_the_readme_lists_every_scene_file_of_the_package():
    """The same list checked against the files themselves: every rodsim/data/*.toml (the
    repository's data/ folder) is in the README's list, and nothing else is."""
    start = README.index("Shipped scenes (`rodsim scenes`")
    end = README.index("A name that is neither a shipped scene nor a file", start)
    listed = {name for name in re.findall(r"`([a-z0-9][a-z0-9-]*)`", README[start:end])
              if name != "reach"}
    files = {path.stem for path in (ROOT / "rodsim" / "data").glob("*.toml")}
    assert len(files) >= 13
    assert listed == files, (f"missing from README: {sorted(files - listed)}; "
                             f"no such file: {sorted(listed - files)}")


def test_the_readme_says_how_to_build_the_docs_site():
    section = README[README.index("## Documentation site"):]
    section = section[:section.index("\n## ")]
    for needed in ("mkdocs build --strict", "mkdocs serve", 'pip install ".[docs]"',
                   "docs/getting-started.md", "docs/gallery.md"):
        assert needed in section, needed


def test_the_files_the_readme_commands_name_are_shipped():
    named = set(re.findall(r"\bexamples/[\w.-]+\.(?:toml|csv|py)\b", README))
    assert {"examples/my-scene.toml", "examples/shape.csv"} <= named
    for path in named:
        assert (ROOT / path).is_file(), path

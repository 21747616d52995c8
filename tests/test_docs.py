"""The front door holds: every code block of the README and of the guides runs, every command
line they show parses, every link between the repository's documents resolves, and nothing in
the repository refers to a path outside it."""

from __future__ import annotations

import re
import shlex
import subprocess
import warnings
from pathlib import Path

import pytest

from batecho.cli.app import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GUIDES = sorted((ROOT / "docs").glob("*.md")) + sorted((ROOT / "docs" / "guide").glob("*.md"))
DOCUMENTS = [README, ROOT / "CONTRIBUTING.md", *GUIDES]


def blocks(path: Path, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def run_blocks(path: Path, where: Path, monkeypatch) -> None:
    """Run the file's python blocks in order, in one namespace, in ``where`` (with the
    repository's examples beside them), failing on any warning."""
    (where / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(where)
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for code in blocks(path, "python"):
            exec(compile(code, f"{path.name}", "exec"), namespace)


def test_every_python_block_of_the_readme_runs(tmp_path, monkeypatch):
    assert len(blocks(README, "python")) >= 2
    run_blocks(README, tmp_path, monkeypatch)


@pytest.mark.parametrize("page", [p for p in GUIDES if blocks(p, "python")], ids=lambda p: p.name)
def test_every_python_block_of_a_guide_runs(page, tmp_path, monkeypatch):
    run_blocks(page, tmp_path, monkeypatch)


def batecho_command_lines() -> list[tuple[str, str]]:
    found = []
    for doc in DOCUMENTS:
        for code in blocks(doc, "bash"):
            for line in code.splitlines():
                line = line.split("#", 1)[0].strip()
                if line.startswith("batecho "):
                    found.append((doc.name, line))
    return found


@pytest.mark.parametrize(("doc", "line"), batecho_command_lines())
def test_every_batecho_command_line_in_the_documents_parses(doc, line):
    argv = shlex.split(line)[1:]
    build_parser(argv).parse_args(argv)


LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


@pytest.mark.parametrize("doc", DOCUMENTS, ids=lambda p: p.name)
def test_every_relative_link_in_a_document_resolves(doc):
    for target in LINK.findall(doc.read_text(encoding="utf-8")):
        if re.match(r"[a-z]+:", target):
            continue  # a URL
        assert (doc.parent / target).exists(), f"{doc.name} links to {target}, which is missing"


def test_nothing_in_the_repository_refers_to_a_path_outside_it():
    files = subprocess.run(
        ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    outside = re.compile(r"\.\./shared|\bMODEL\.md\b")
    me = Path(__file__).relative_to(ROOT).as_posix()
    bad = []
    for name in files:
        path = ROOT / name
        if name == me or not path.is_file() or path.suffix in {".png", ".obj", ".lock"}:
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        bad += [f"{name}: {m.group(0)}" for m in outside.finditer(text)]
    assert not bad, bad


def extras_table(path: Path) -> set[str]:
    """The extras named in the first column of a document's ``| extra | ...`` table."""
    text = path.read_text(encoding="utf-8")
    table = re.search(r"^\| extra \|.*?\n((?:\|.*\n)+)", text, re.M)
    assert table, f"{path.name} has no extras table"
    return set(re.findall(r"^\| `([\w-]+)` \|", table.group(1), re.M))


@pytest.mark.parametrize(
    "doc", [README, ROOT / "docs" / "guide" / "install.md"], ids=lambda p: p.name
)
def test_the_extras_table_names_every_extra_the_package_declares(doc):
    import tomllib

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"][
        "optional-dependencies"
    ]
    assert extras_table(doc) == set(declared)


def test_the_readme_links_every_guide():
    text = README.read_text(encoding="utf-8")
    linked = {(ROOT / target).resolve() for target in LINK.findall(text)}
    assert not [p.name for p in GUIDES if p.resolve() not in linked and p.name != "index.md"]

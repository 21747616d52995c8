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


def table_rows(path: Path) -> dict[str, set[str]]:
    """The first column of each row of a guide's key tables -> the `names` in its second."""
    rows = re.findall(r"^\| ([^|]+) \| (.+) \|$", path.read_text(encoding="utf-8"), re.M)
    names = re.compile(r"\[*([\w.]+)\]*(?: = .*)?")
    return {
        label.strip("`"): {m.group(1) for span in re.findall(r"`([^`]+)`", keys)
                           if (m := names.fullmatch(span))}
        for label, keys in rows
    }  # fmt: skip


def test_the_cli_guide_key_table_names_every_key_of_a_scene_file():
    from batecho.scenefile import schema

    rows = table_rows(ROOT / "docs" / "guide" / "cli.md")
    tables = {"scene", "sonar", "flight", "output", "call"}
    expected = {
        "top level": set(schema._TOP) - tables,
        "[scene]": set(schema._SCENE) - {"tree"} | {"scene.tree"},
        "[flight]": set(schema._FLIGHT) - {"mount"} | {"flight.mount"} | set(schema._MOUNT),
        "[call]": set(schema._CALL),
        "[output]": set(schema._OUTPUT),
        "[sonar]": {"horseshoe_bat_khz", "sonar.binaural", "sonar.receivers"}
        | set(schema._BINAURAL) - {"ear_beam"}
        | set(schema._RECEIVER) - {"beam"},
    }
    for label, keys in expected.items():
        assert not keys - rows[label], (label, sorted(keys - rows[label]))


def test_the_scene_file_sonar_table_takes_every_sonar_parameter_as_the_cli_guide_says():
    import inspect

    import batecho
    from batecho.scenefile import schema

    assert set(inspect.signature(batecho.Sonar).parameters) <= set(schema._SONAR)


def test_the_datasets_guide_names_exactly_the_sonar_keys_a_spec_takes():
    import dataclasses

    from batecho.dataset.spec import SonarSpec

    row = table_rows(ROOT / "docs" / "guide" / "datasets.md")["[sonar]"]
    refused = {"absorption", "record_tail_s", "beam"}
    assert row - {"batecho.Sonar"} == {f.name for f in dataclasses.fields(SonarSpec)} | refused


@pytest.mark.parametrize("key", ["absorption", "record_tail_s", "beam"])
def test_a_sonar_parameter_the_datasets_guide_says_is_refused_is_refused(key):
    from batecho.dataset import DatasetSpec
    from batecho.dataset.spec import SpecError

    text = (ROOT / "examples" / "dataset-small.toml").read_text(encoding="utf-8")
    text = text.replace("[sonar]\n", f"[sonar]\n{key} = 1.0\n", 1)
    with pytest.raises(SpecError, match=key):
        DatasetSpec.from_toml_string(text)


def test_the_dataset_example_offers_a_scene_kind_the_spec_accepts():
    from batecho.dataset import DatasetSpec

    text = (ROOT / "examples" / "dataset-small.toml").read_text(encoding="utf-8")
    kinds = re.search(r'^kind = "(\w+)" +# or "(\w+)".*$', text, re.M)
    assert kinds, "examples/dataset-small.toml offers no other scene kind"
    for kind in kinds.groups():
        spec = DatasetSpec.from_toml_string(text.replace(kinds.group(0), f'kind = "{kind}"'))
        assert spec.scene.kind == kind


def test_the_api_page_of_batecho_documents_every_top_level_name():
    import types

    import batecho

    page = (ROOT / "docs" / "api" / "batecho.md").read_text(encoding="utf-8")
    documented = set(re.findall(r"^::: batecho\.(\w+)$", page, re.M))
    names = {n for n in batecho.__all__ if not n.startswith("_")}
    modules = {n for n in names if isinstance(getattr(batecho, n), types.ModuleType)}
    assert not sorted(names - modules - documented)

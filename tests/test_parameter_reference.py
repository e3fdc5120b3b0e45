"""The parameter reference is generated from the schemas, and the schemas are coherent."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mavhelm.companion.reference import PROCESS_SCHEMAS, reference
from mavhelm.core.geodesy import GLOBAL_SCHEMA
from mavhelm.core.params import Schema
from mavhelm.tasks.registry import TASK_TYPES, known_types

ROOT = Path(__file__).resolve().parents[1]
SCHEMAS: list[Schema] = [GLOBAL_SCHEMA, *(s for s, _ in PROCESS_SCHEMAS.values()),
                         *(cls.schema() for cls in dict.fromkeys(TASK_TYPES.values()))]


def test_docs_parameters_md_is_what_the_code_declares():
    on_disk = (ROOT / "docs" / "parameters.md").read_text()
    assert on_disk == reference(), (
        "docs/parameters.md is stale: regenerate it with `mavhelm params > docs/parameters.md`")


def test_mavhelm_params_prints_the_reference():
    out = subprocess.run([sys.executable, "-m", "mavhelm.cli", "params"], capture_output=True,
                         text=True, timeout=60, check=True).stdout
    assert out == reference()


def test_every_task_type_and_block_is_in_the_reference_and_the_readme():
    text = reference()
    readme = (ROOT / "README.md").read_text()
    for cls in set(TASK_TYPES.values()):
        assert f"### Task = {cls.keyword}" in text
        for p in cls.schema().params:
            assert f"| `{p.name}` |" in text, (cls.keyword, p.name)
    for keyword in known_types():
        assert f"`{keyword}`" in readme, f"README's task table misses {keyword}"
    for name in PROCESS_SCHEMAS:
        assert f"### ProcessConfig = {name}" in text
    assert "docs/parameters.md" in readme


@pytest.mark.parametrize("schema", SCHEMAS, ids=lambda s: s.owner)
def test_every_default_is_a_value_its_own_declaration_accepts(schema):
    for p in schema.params:
        if p.required or p.default is None:
            continue
        if p.repeat:
            assert p.default == [] or all(p.kind.check_value(v) for v in p.default), p.name
        else:
            assert p.kind.check_value(p.default), f"{schema.owner}: {p.name} = {p.default!r}"


@pytest.mark.parametrize("schema", SCHEMAS, ids=lambda s: s.owner)
def test_every_parameter_says_what_it_is(schema):
    for p in schema.params:
        assert p.doc, f"{schema.owner}: {p.name} has no doc line"


def test_every_row_of_a_parameter_table_has_its_five_cells():
    """A `|` inside a cell (``Allow``'s ``a | b`` syntax) is escaped, so the table holds."""
    import re

    for line in reference().splitlines():
        if line.startswith("| `") and line.count("|") > 3:
            cells = re.split(r"(?<!\\)\|", line)[1:-1]
            assert len(cells) in (2, 3, 5), line

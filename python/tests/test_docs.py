"""The `python` blocks of docs/python.md run as written: in order, as one script, in a scratch
directory holding the repository's models/, examples/ and tests/data/klipper/ and the measurements.csv the README's
`legwise simulate --model models/5r.yaml --out measurements.csv` writes."""

import os
import re
import shutil

from support import ROOT, command


def blocks(path):
    """The code of every ```python block of a Markdown file, in order."""
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), flags=re.S | re.M)


def test_the_python_blocks_of_docs_python_md_run(tmp_path, monkeypatch, capsys):
    code = blocks(ROOT / "docs" / "python.md")
    assert len(code) >= 5
    for directory in ("models", "examples", "tests/data/klipper"):
        shutil.copytree(ROOT / directory, tmp_path / directory)
    status, _, err = command(
        "simulate", "--model", "models/5r.yaml", "--out", "measurements.csv", cwd=tmp_path
    )
    assert status == 0, err
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "docs"}
    for k, block in enumerate(code):
        try:
            exec(compile(block, f"docs/python.md block {k + 1}", "exec"), namespace)
        except Exception as error:  # the block's number and code say where
            raise AssertionError(f"docs/python.md block {k + 1} fails:\n{block}") from error
    assert os.path.exists(tmp_path / "calibrated.yaml")

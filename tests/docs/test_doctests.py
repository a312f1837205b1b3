"""The examples in the docstrings of every dualpose module run as doctests.

Each module is imported by its package name and its docstrings collected with the standard library's ``doctest``
(pytest's ``--doctest-modules`` would import ``evaluation/`` and ``pipelines/``, which have no ``__init__.py``, under
a second, top-level name).
"""

from __future__ import annotations

import doctest
import importlib
import os
from pathlib import Path

import pytest

import dualpose

PACKAGE = Path(dualpose.__file__).parent


def _modules() -> list[str]:
    names = []
    for root, dirs, files in os.walk(PACKAGE):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        rel = Path(root).relative_to(PACKAGE).parts
        prefix = ".".join(("dualpose", *rel))
        for f in sorted(files):
            if f.endswith(".py"):
                names.append(prefix if f == "__init__.py" else f"{prefix}.{f[:-3]}")
    return names


MODULES = _modules()
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def test_modules_are_found() -> None:
    assert {"dualpose", "dualpose.algebra.quat", "dualpose.evaluation.metrics", "dualpose.cli.main"} <= set(MODULES)


@pytest.mark.parametrize("name", [m for m in MODULES if m != "dualpose._native"])
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    tests = [t for t in doctest.DocTestFinder().find(module, name) if t.examples]
    if not tests:
        return
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for t in tests:
        runner.run(t)
    failed, attempted = runner.summarize(verbose=False)
    assert attempted > 0
    assert failed == 0, f"{failed} of {attempted} docstring examples of {name} failed (output above)"

"""The type stub of the compiled module (``src/dualpose/_native.pyi``) says what the module holds: regenerated from
the module by ``src/native/make_stub.py``, it equals the committed file; and the package is marked typed."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from dualpose import _native

ROOT = Path(__file__).resolve().parents[1]


def _maker():
    spec = importlib.util.spec_from_file_location("make_stub", ROOT / "src" / "native" / "make_stub.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_committed_stub_matches_the_module() -> None:
    maker = _maker()
    assert maker.STUB.read_text(encoding="utf-8") == maker.stub_text(_native), (
        "src/dualpose/_native.pyi is out of date: run .venv/bin/python src/native/make_stub.py"
    )


def test_stub_names_every_public_member_with_its_kind() -> None:
    tree = ast.parse((ROOT / "src" / "dualpose" / "_native.pyi").read_text(encoding="utf-8"))
    functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    annotated = {n.target.id: ast.unparse(n.annotation) for n in tree.body if isinstance(n, ast.AnnAssign)}
    classes = {n.name for n in tree.body if isinstance(n, ast.ClassDef)}
    for name in (n for n in dir(_native) if not n.startswith("__")):
        value = getattr(_native, name)
        if isinstance(value, np.ufunc):
            assert annotated[name] == "np.ufunc", name
        elif isinstance(value, type):
            assert name in classes, name
        elif callable(value):
            params = [a.arg for a in functions[name].args.posonlyargs]
            assert params == [] or value.__doc__.startswith(f"{name}({params[0]}"), name
        else:
            assert annotated[name] == type(value).__name__, name
    assert len(functions) + len(annotated) + len(classes) == len([n for n in dir(_native) if not n.startswith("__")])


def test_parameters_read_from_the_docstring() -> None:
    maker = _maker()
    doc = "f(x, P (15, 15), gyro (k, 3), noise (6,), out=None): ..."
    assert maker._parameters("f", doc) == ["x", "P", "gyro", "noise", "out"]
    assert maker._parameters("f", "Something else.") == []
    assert maker._parameters("f", "f(<the arguments of g>, XA, PA) -> int: ...") == []


def test_package_is_marked_typed() -> None:
    assert (ROOT / "src" / "dualpose" / "py.typed").is_file()


def test_return_types_read_from_the_docstring() -> None:
    maker = _maker()
    assert maker._return_type("f", "f(x, P (15, 15)): in place.") == "None"
    assert maker._return_type("f", "f(a, b) -> int: count.") == "int"
    assert maker._return_type("f", "f(state, t) -> x (16,): the state.") == "NDArray[np.float64]"
    assert maker._return_type("f", "f(state) -> (x (16,), P (225,), t0, tc, samples): copies.") == (
        "tuple[NDArray[np.float64], NDArray[np.float64], float, float, int]"
    )
    with pytest.raises(ValueError, match="not a word"):
        maker._return_type("f", "f(a) -> something: ?")

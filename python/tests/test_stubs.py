"""The type stubs (`buridan/_buridan.pyi`) describe the native module exactly:
every public class, function and method, and nothing else."""

import ast
import inspect
from pathlib import Path

import buridan
from buridan import _buridan

STUB = Path(buridan.__file__).with_name("_buridan.pyi")


def stub_tree():
    tree = ast.parse(STUB.read_text())
    names, classes = set(), {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names.add(node.name)
            classes[node.name] = {
                n.name if isinstance(n, ast.FunctionDef) else n.target.id
                for n in node.body
                if isinstance(n, (ast.FunctionDef, ast.AnnAssign))
            }
        elif isinstance(node, ast.FunctionDef):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            names.add(node.target.id)
    return names, classes


def test_stub_ships_with_the_package():
    assert STUB.is_file() and STUB.with_name("py.typed").is_file()


def test_stub_lists_every_public_name():
    names, _ = stub_tree()
    public = {n for n in dir(_buridan) if not n.startswith("_")} | {"__version__"}
    assert public == names


def test_stub_lists_every_method_and_property():
    _, classes = stub_tree()
    for name, members in classes.items():
        cls = getattr(_buridan, name)
        if issubclass(cls, BaseException):
            continue
        runtime = {
            m for m, v in vars(cls).items()
            if not m.startswith("_") or m in ("__init__", "__len__")
        }
        if cls.__text_signature__ is not None:  # a #[new] constructor
            runtime.add("__init__")
        assert members == runtime, name


def test_public_callables_have_docstrings():
    for name in dir(_buridan):
        obj = getattr(_buridan, name)
        if name.startswith("_") or not (inspect.isclass(obj) or callable(obj)):
            continue
        assert (obj.__doc__ or "").strip(), name
        if inspect.isclass(obj) and not issubclass(obj, BaseException):
            for m, v in vars(obj).items():
                if not m.startswith("_"):
                    assert (getattr(v, "__doc__", "") or "").strip(), f"{name}.{m}"

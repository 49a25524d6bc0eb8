"""The type stub `_cdsm.pyi` describes exactly what the extension exports."""

import ast
from importlib import resources

import cdsm._cdsm as ext


def _stub():
    tree = ast.parse(resources.files("cdsm").joinpath("_cdsm.pyi").read_text(encoding="utf-8"))
    top, methods = set(), set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            top.add(node.name)
        elif isinstance(node, ast.ClassDef):
            top.add(node.name)
            if node.name == "CoreRobot":
                methods = {b.name for b in node.body if isinstance(b, ast.FunctionDef)}
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if node.target.id.isupper() and node.target.id not in ("F64", "Bool", "U32", "U64"):
                top.add(node.target.id)
    return top, methods


def test_stub_lists_every_export_and_nothing_else():
    top, methods = _stub()
    exported = {k for k in dir(ext) if not k.startswith("_")}
    assert top == exported
    core = {k for k in dir(ext.CoreRobot) if not k.startswith("_")}
    assert methods == core

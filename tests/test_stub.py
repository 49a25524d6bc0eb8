"""The type stub `_cdsm.pyi` describes exactly what the extension exports:
its functions, constants, classes, the methods of `CoreRobot` and the fields
of every result class."""

import ast
from importlib import resources

import cdsm._cdsm as ext

ALIASES = ("F64", "Bool", "U8", "U32", "U64")


def _stub():
    tree = ast.parse(resources.files("cdsm").joinpath("_cdsm.pyi").read_text(encoding="utf-8"))
    top, members = set(), {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            top.add(node.name)
        elif isinstance(node, ast.ClassDef):
            top.add(node.name)
            members[node.name] = {b.name for b in node.body if isinstance(b, ast.FunctionDef)} | {
                b.target.id for b in node.body if isinstance(b, ast.AnnAssign)}
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if node.target.id.isupper() and node.target.id not in ALIASES:
                top.add(node.target.id)
    return top, members


def test_stub_lists_every_export_and_nothing_else():
    top, members = _stub()
    exported = {k for k in dir(ext) if not k.startswith("_")}
    assert top == exported
    for name, names in members.items():
        if name == "CdsmInputError":
            continue
        cls = getattr(ext, name)
        assert names == {k for k in dir(cls) if not k.startswith("_")}, name

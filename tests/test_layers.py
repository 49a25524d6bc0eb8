"""The layers of the code stay layers: no Rust module depends on itself
through others (the `crate::` and `super::` paths of the non-test code,
file by file and folder by folder), and the Python packages `calibration`
and `accuracy` import each other one way at most (house_check covers the
Python modules' cycles, not these)."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUST = ROOT / "rust"
PYTHON = ROOT / "python" / "cdsm"


def _module_of(path: Path) -> str:
    """`rust/simd/math.rs` -> `simd::math`, `rust/simd/mod.rs` -> `simd`,
    `rust/lib.rs` -> `` (the crate root)."""
    parts = list(path.relative_to(RUST).with_suffix("").parts)
    if parts[-1] in ("mod", "lib"):
        parts.pop()
    return "::".join(parts)


def _blank(text: str, start: int, end: int) -> str:
    """`text` with `[start, end)` replaced by spaces (newlines kept)."""
    return text[:start] + re.sub(r"[^\n]", " ", text[start:end]) + text[end:]


def _code(text: str) -> str:
    """The Rust source without comments, string and char literals, and
    without the items under `#[cfg(test)]` (a test module anywhere in the
    file, not only at its end)."""
    out, i, n = [], 0, len(text)
    while i < n:
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            i = n if j < 0 else j + 2
        elif text[i] == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append('""')
            i = j + 1
        elif text[i] == "'" and re.match(r"'(\\.|[^\\'])'", text[i:i + 4]):
            i += len(re.match(r"'(\\.|[^\\'])'", text[i:i + 4]).group(0))
            out.append("' '")
        else:
            out.append(text[i])
            i += 1
    code = "".join(out)
    while (m := re.search(r"#\[cfg\(test\)\]", code)):
        # the attributed item: to its block's closing brace, or to `;`
        j, depth = m.end(), 0
        while j < len(code):
            if code[j] == "{":
                depth += 1
            elif code[j] == "}":
                depth -= 1
                if depth == 0:
                    break
            elif code[j] == ";" and depth == 0:
                break
            j += 1
        code = _blank(code, m.start(), j + 1)
    return code


def _paths(code: str):
    """The paths of every `use` tree and every inline `crate::`/`super::`
    path, as lists of segments (`use a::{b, c::d}` gives `a::b`, `a::c::d`)."""

    def expand(prefix, tree):
        tree = tree.strip()
        if not tree:
            return
        m = re.match(r"([\w:]*?)::\{(.*)\}$", tree, re.S)
        if tree.startswith("{") and tree.endswith("}"):
            m, inner, head = None, tree[1:-1], ""
        elif m:
            head, inner = m.group(1), m.group(2)
        else:
            yield prefix + [s for s in re.split(r"\s*::\s*", tree.split(" as ")[0]) if s]
            return
        depth, part = 0, ""
        for ch in inner + ",":
            if ch == "," and depth == 0:
                yield from expand(prefix + [s for s in head.split("::") if s], part)
                part = ""
                continue
            depth += (ch == "{") - (ch == "}")
            part += ch

    for m in re.finditer(r"\buse\s+([^;]+);", code):
        yield from expand([], m.group(1))
    rest = re.sub(r"\buse\s+[^;]+;", "", code)
    for m in re.finditer(r"\b((?:crate|super)(?:::\w+)+)", rest):
        yield m.group(1).split("::")


def rust_graph():
    """Edges between the crate's modules (files) of the non-test code."""
    files = sorted(RUST.rglob("*.rs"))
    modules = {_module_of(p) for p in files}
    edges = {}
    for p in files:
        here = _module_of(p)
        parent = here.rsplit("::", 1)[0] if "::" in here else ""
        if p.name == "mod.rs":
            parent = here
        targets = set()
        for segs in _paths(_code(p.read_text(encoding="utf-8"))):
            if segs[0] == "crate":
                base = []
            elif segs[0] == "super":
                base = parent.split("::") if parent else []
                while segs and segs[0] == "super":
                    segs = segs[1:]
                    if segs and segs[0] == "super":
                        base = base[:-1]
                segs = ["crate"] + segs
            else:
                continue
            # the longest module that the path names
            names = base + [s for s in segs[1:] if s != "self"]
            for k in range(len(names), 0, -1):
                cand = "::".join(names[:k])
                if cand in modules:
                    if cand != here:
                        targets.add(cand)
                    break
        edges[here] = targets
    return edges


def cycles(edges):
    """The strongly connected components with more than one node (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def folders(edges):
    """The edges between top-level modules (a folder and its files as one)."""
    top = {}
    for a, bs in edges.items():
        ta = a.split("::")[0]
        top.setdefault(ta, set())
        for b in bs:
            tb = b.split("::")[0]
            if tb != ta and ta and tb:
                top[ta].add(tb)
    return top


def test_the_graph_reader_sees_the_edges_it_should():
    # a test module in the middle of a file is skipped, inline paths count,
    # `use` groups expand, comments and strings do not count
    code = _code(
        "use crate::a::{b, c::{d, e as f}};\n"
        "// crate::comment::x\n"
        '#[cfg(test)]\nmod tests { use crate::hidden; fn f() { let s = "}"; } }\n'
        "fn g() { crate::inline::f(); let s = \"crate::string::x\"; }\n"
        "#[cfg(test)]\nuse crate::also_hidden;\n"
        "fn h() {}\n"
    )
    paths = {"::".join(p) for p in _paths(code)}
    assert paths == {"crate::a::b", "crate::a::c::d", "crate::a::c::e", "crate::inline::f"}, paths
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_the_graph_holds_known_edges():
    edges = rust_graph()
    assert "error" in edges["model"]
    assert "lm" in edges["solve"]
    assert "python::convert" in edges["python::robot"]
    assert "simd::lanes" in edges["simd::math"]


def test_no_rust_module_cycle():
    edges = rust_graph()
    assert cycles(edges) == []
    assert cycles(folders(edges)) == []


def test_rows_depends_on_nothing_of_the_physics():
    # the thread and batch-shape helpers every algorithm uses sit below them
    assert rust_graph()["rows"] <= {"error", "lm"}


def _python_package_edges():
    """(importing package, imported package) pairs among cdsm's subpackages,
    imports inside functions included."""
    out = set()
    for path in PYTHON.rglob("*.py"):
        rel = path.relative_to(PYTHON).parts
        if len(rel) < 2:
            continue
        here = rel[0]
        pkg = ["cdsm", *rel[:-1]]
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg[: len(pkg) - node.level + 1]
                    names = [".".join(base + ([node.module] if node.module else []))]
                    if not node.module:
                        names = [names[0] + "." + a.name for a in node.names]
                else:
                    names = [node.module or ""]
            else:
                continue
            for name in names:
                parts = name.split(".")
                if len(parts) > 1 and parts[0] == "cdsm" and parts[1] != here:
                    out.add((here, parts[1]))
    return out


def test_the_python_edges_are_read():
    edges = _python_package_edges()
    assert ("cli", "report") in edges or ("cli", "accuracy") in edges
    assert ("calibration", "accuracy") in edges


def test_calibration_and_accuracy_import_one_way():
    edges = _python_package_edges()
    assert not (("calibration", "accuracy") in edges and ("accuracy", "calibration") in edges)


def test_the_plant_module_forwards_its_01_names_with_a_warning():
    """`cdsm.plant` was the 0.1 alias of `cdsm.calibration.plant`; it is now the plant's own
    module (below both packages). Its 0.1 names that stayed in calibration forward there
    with a DeprecationWarning; the plant's functions are the same objects on both paths."""
    import cdsm.calibration.plant as cal
    import cdsm.plant as plant

    with pytest.warns(DeprecationWarning, match="cdsm.calibration.plant.VirtualPrototype"):
        assert plant.VirtualPrototype is cal.VirtualPrototype
    assert plant.predict is cal.predict and plant.layout is cal.layout
    with pytest.raises(AttributeError):
        plant.no_such_name  # noqa: B018


def _documented_layers():
    """{module: layer} from the table of docs/architecture.md ("Layers")."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    out = {}
    for m in re.finditer(r"^\|\s*(\d+)\s*\|\s*([a-z_, ]+?)\s*\|\s*$", section, re.M):
        for name in m.group(2).split(","):
            assert name.strip() not in out, f"{name.strip()} listed twice"
            out[name.strip()] = int(m.group(1))
    return out


def test_the_documented_layers_are_the_code_s():
    """docs/architecture.md's layer table is true: every top-level Rust module is in
    exactly one layer, and every module uses modules of its own layer or below."""
    layers = _documented_layers()
    edges = {a: bs for a, bs in folders(rust_graph()).items() if a}
    assert set(layers) == set(edges), (set(edges) - set(layers), set(layers) - set(edges))
    upward = sorted((a, b) for a, bs in edges.items() for b in bs if layers[b] > layers[a])
    assert upward == [], upward

"""No label grammar and no list of labels outside the core: the dashboard and the backend read the registry.

Issue 19, point 2: the dashboard builds its pickers, messages, colours, order and parsing from
``GET /api/algorithms``, and the backend's sort keys use the core's parser. This test reads the code
of ``frontend/js/`` and ``backend/`` (comments and docstrings left out: prose may name a label) and
fails naming ``file:line`` for

* a string whose whole text is a label, or a label form (``'mgrao-max'``, ``'uniform'``,
  ```mgrao-${x}:1```, ``'mgrao-x:1'``): a label written into the code, alone or in a list;
* a regular expression holding a label form's fixed text (``/^mgrao-(\\d+):1$/``,
  ``.replace(/^mgrao-/, '')``): label parsing.

What counts as a label comes from the registry itself (each form's pattern and template), so a new
family is covered without a change here. Prose inside a longer string ("% from uniform") is not a label.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from mgrao_core.algorithms import registry

ROOT = Path(__file__).resolve().parents[1]
FORMS = [form for family in registry(None) for form in family["forms"]]
PATTERNS = [re.compile(form["pattern"]) for form in FORMS]
# a form with its arguments named or marked (mgrao-x:1, mgrao-<x>:1, mgrao-{x}:1, mgrao-x:y) is a label form too
SPELLINGS = {form["template"].replace(f"{{{form['argument']}}}", mark.format(form["argument"]))
             .replace(f"{{{form.get('second_argument')}}}", mark.format(form.get("second_argument")))
             for form in FORMS if form["argument"] for mark in ("{}", "<{}>", "{{{}}}")}
# the fixed text around an argument (mgrao-), what a parser of those labels has to match
FRAGMENTS = sorted({part for form in FORMS if form["argument"]
                    for part in form["template"].split(f"{{{form['argument']}}}") if len(part) >= 4})
REGEX_SIGNS = ("^", "$", "\\d", "(?", "[0-9]")


def shown(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else path.name


def is_label(text: str) -> bool:
    """``text`` is a label or a label form, as the core reads labels (stripped, lower-cased)."""
    text = text.strip().lower()
    return bool(text) and (text in SPELLINGS or any(p.match(text) for p in PATTERNS))


def regex_with_fragment(text: str) -> bool:
    return any(fragment in text.lower() for fragment in FRAGMENTS)


# ---- JavaScript ------------------------------------------------------------------------------------

_JS_TOKEN = re.compile(
    r"(?P<block>/\*[\s\S]*?\*/)"
    r"|(?P<line>//[^\n]*)"
    r"|(?P<string>'(?:[^'\\\n]|\\.)*'|\"(?:[^\"\\\n]|\\.)*\")"
    r"|(?P<template>`(?:[^`\\]|\\.)*`)"
    r"|(?P<regex>(?<=[=(,:;!&|?{}\[\n]\s)/(?![/*\s])(?:[^/\\\n\[]|\\.|\[(?:[^\]\\\n]|\\.)*\])+/[dgimsuy]*"
    r"|(?<=[=(,:;!&|?{}\[\n])/(?![/*\s])(?:[^/\\\n\[]|\\.|\[(?:[^\]\\\n]|\\.)*\])+/[dgimsuy]*)"
)
_INTERPOLATION = re.compile(r"\$\{[^}]*\}")


def js_findings(path: Path) -> list[str]:
    source = path.read_text()
    found = []
    for match in _JS_TOKEN.finditer(source):
        kind = match.lastgroup
        token = match.group()
        line = source.count("\n", 0, match.start()) + 1
        where = f"{shown(path)}:{line}"
        if kind == "string" and is_label(token[1:-1]):
            found.append(f"{where}: a label in the code: {token}")
        elif kind == "template" and is_label(_INTERPOLATION.sub("0", token[1:-1])):
            found.append(f"{where}: a label built in the code: {token}")
        elif kind == "regex" and regex_with_fragment(token):
            found.append(f"{where}: label parsing: {token}")
        elif kind == "string" and regex_with_fragment(token) and any(s in token for s in REGEX_SIGNS):
            found.append(f"{where}: label parsing (a pattern in a string): {token}")
    return found


# ---- Python ----------------------------------------------------------------------------------------


def _docstrings(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            ids.add(id(body[0].value))
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):  # attribute docstrings
            ids.add(id(node.value))
    return ids


def py_findings(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    skip = _docstrings(tree)
    found = []
    for node in ast.walk(tree):
        where = f"{shown(path)}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, ast.JoinedStr):
            text = "".join(v.value if isinstance(v, ast.Constant) else "0" for v in node.values)
            if is_label(text):
                found.append(f"{where}: a label built in the code: {ast.unparse(node)}")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            if is_label(node.value):
                found.append(f"{where}: a label in the code: {node.value!r}")
            elif regex_with_fragment(node.value) and any(s in node.value for s in REGEX_SIGNS):
                found.append(f"{where}: label parsing: {node.value!r}")
    return found


def test_the_checks_catch_what_they_are_for(tmp_path: Path) -> None:
    assert is_label("mgrao-max") and is_label("uniform") and is_label("mgrao-12:1") and is_label("mgrao-x:1")
    assert not is_label("% from uniform") and not is_label("mgrao-study-draft")
    sample = tmp_path / "probe.js"
    sample_py = tmp_path / "probe.py"
    sample.write_text("// 'mgrao-max' in a comment is prose\nconst A = ['uniform', 'oracle'];\n"
                      "const m = /^mgrao-(\\d+):1$/.exec(name);\nconst b = `mgrao-${x}:1`;\n"
                      "const t = 'the % from uniform';\nx.replace(/^mgrao-/, '');\n")
    sample_py.write_text('"""The mgrao-max label, in prose."""\nA = ("uniform", "mgrao-1:1")\n'
                         'R = r"^mgrao-(\\d+):1$"\nB = f"mgrao-{x}:1"\n')
    js = js_findings(sample)
    assert [f.split(":")[1] for f in js] == ["2", "2", "3", "4", "6"], js
    py = py_findings(sample_py)
    assert sorted(int(f.split(":")[1]) for f in py) == [2, 2, 3, 4], py


def test_no_label_grammar_or_label_list_in_the_dashboard_or_the_backend() -> None:
    found = [f for path in sorted((ROOT / "frontend" / "js").glob("*.js")) for f in js_findings(path)]
    found += [f for path in sorted((ROOT / "backend").rglob("*.py")) if "migrations" not in path.parts
              for f in py_findings(path)]
    assert not found, "labels belong to the core's registry (GET /api/algorithms):\n" + "\n".join(found)

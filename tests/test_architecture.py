"""The shape of the package, read from its source with ``ast`` (every import counts, those
inside functions too): no import cycle between modules, the packages in one order (a lower
one never imports a higher one), no private name imported from another module, no module
over 650 lines, no package exporting a name one of its submodules has; and no test module
importing another."""

from __future__ import annotations

import ast
import textwrap
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.helpers import ROOT

#: Lower packages never import higher ones. Modules directly in ``tracecheck/`` (errors,
#: outputs, _lazy, …: the helpers every layer uses) come first, under the name "top".
ORDER = ("top", "b", "episodes", "checking", "live", "stats", "search", "render", "interop",
         "cli")
MAX_LINES = 650


@dataclass(frozen=True)
class Import:
    """Module ``source`` imports ``target`` (a module of the package) at ``line``; ``name`` is
    the name taken from it (``from target import name``), "" for a whole module."""

    source: str
    target: str
    line: int
    name: str = ""


class Package:
    """The modules of one package under ``root`` and the imports between them."""

    def __init__(self, root: Path, name: str) -> None:
        self.root, self.name = root, name
        self.files: dict[str, Path] = {}
        for path in sorted((root / name).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            self.files[".".join(parts)] = path
        self.trees = {m: ast.parse(p.read_text(encoding="utf-8"), str(p))
                      for m, p in self.files.items()}
        self.imports = [i for m in self.files for i in self._imports_of(m)]

    def where(self, imp: Import) -> str:
        return f"{self.files[imp.source].relative_to(self.root)}:{imp.line}"

    def _module_of(self, dotted: str) -> str | None:
        """The package module that ``dotted`` names or lies in (None: outside the package)."""
        while dotted not in self.files:
            if "." not in dotted:
                return None
            dotted = dotted.rsplit(".", 1)[0]
        return dotted

    def _absolute(self, module: str, node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        base = module.split(".")
        if self.files[module].name != "__init__.py":
            base.pop()
        base = base[:len(base) - node.level + 1]
        return ".".join(base + ([node.module] if node.module else []))

    def _defined_in(self, package: str, name: str) -> str:
        """Where a package's ``__init__`` gets ``name`` from: ``from .m import name``, or a
        dict literal mapping it to a submodule (the lazy names of ``_lazy.lazy_names``)."""
        for node in ast.walk(self.trees[package]):
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module and \
                    any(a.name == name for a in node.names):
                return self._module_of(f"{package}.{node.module}") or package
            if isinstance(node, ast.Dict):
                for key, value in zip(node.keys, node.values):
                    if isinstance(key, ast.Constant) and key.value == name and \
                            isinstance(value, ast.Constant) and isinstance(value.value, str):
                        return self._module_of(f"{package}.{value.value}") or package
        return package

    def _imports_of(self, module: str):
        for node in ast.walk(self.trees[module]):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    target = self._module_of(alias.name)
                    if target is not None:
                        yield Import(module, target, node.lineno)
            elif isinstance(node, ast.ImportFrom):
                base = self._absolute(module, node)
                target = self._module_of(base)
                if target is None:
                    continue
                for alias in node.names:
                    if f"{base}.{alias.name}" in self.files:  # a submodule
                        yield Import(module, f"{base}.{alias.name}", node.lineno)
                    elif self.files[target].name == "__init__.py":
                        yield Import(module, self._defined_in(target, alias.name), node.lineno,
                                     alias.name)
                    else:
                        yield Import(module, target, node.lineno, alias.name)

    def layer(self, module: str) -> str:
        """The package a module belongs to; modules directly in the package are "top", but
        for ``__main__`` (``python -m``), which is the command line and belongs with it."""
        parts = module.split(".")
        if parts[1:] == ["__main__"]:
            return ORDER[-1]
        return parts[1] if len(parts) > 1 and f"{parts[0]}.{parts[1]}" in self.files and \
            self.files[f"{parts[0]}.{parts[1]}"].name == "__init__.py" else "top"


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (each sorted)."""
    from tracecheck.graphs import components

    ordered = {v: sorted(graph.get(v, ())) for v in sorted(graph)}
    return sorted(sorted(c) for c in components(ordered) if len(c) > 1)


# ------------------------------------------------------------------ the four checks


def module_cycles(pkg: Package) -> list[str]:
    graph = defaultdict(set)
    for i in pkg.imports:
        if i.source != i.target:
            graph[i.source].add(i.target)
    problems = []
    for cycle in strongly_connected(graph):
        edges = sorted({f"{i.source} -> {i.target} ({pkg.where(i)})" for i in pkg.imports
                        if i.source in cycle and i.target in cycle and i.source != i.target})
        problems.append(f"cycle {' <-> '.join(cycle)}:\n    " + "\n    ".join(edges))
    return problems


def package_cycles(pkg: Package) -> list[str]:
    across = defaultdict(list)  # (package, package it imports) -> the import lines, sorted
    for source, line, target in sorted({(i.source, i.line, i.target) for i in pkg.imports}):
        if pkg.layer(source) != pkg.layer(target):
            across[pkg.layer(source), pkg.layer(target)].append(Import(source, target, line))
    graph = defaultdict(set)
    for low, high in across:
        graph[low].add(high)
    problems = []
    for cycle in strongly_connected(graph):
        edges = []
        for (a, b), imports in sorted(across.items()):
            if a in cycle and b in cycle:
                first = imports[0]
                more = f" and {len(imports) - 1} more" if len(imports) > 1 else ""
                edges.append(f"{a} -> {b}: {first.source} -> {first.target} "
                             f"({pkg.where(first)}){more}")
        problems.append(f"packages {' <-> '.join(cycle)} on a cycle:\n    "
                        + "\n    ".join(edges))
    return problems


def upward_imports(pkg: Package, order=ORDER) -> list[str]:
    rank = {layer: k for k, layer in enumerate(order)}
    problems = sorted({f"package {pkg.layer(m)} ({m}) has no place in the order {order}"
                       for m in pkg.files if pkg.layer(m) not in rank})
    for i in pkg.imports:
        low, high = pkg.layer(i.source), pkg.layer(i.target)
        if rank.get(high, -1) > rank.get(low, len(order)):
            problems.append(f"{low} imports {high}, which comes after it: {i.source} -> "
                            f"{i.target} ({pkg.where(i)})")
    return sorted(set(problems))


def private_imports(pkg: Package) -> list[str]:
    return sorted({f"{i.source} imports {i.name} from {i.target} ({pkg.where(i)})"
                   for i in pkg.imports if i.source != i.target
                   and i.name.startswith("_") and not i.name.startswith("__")})


def shadowed_names(pkg: Package) -> list[str]:
    """Names a package exports (``from .m import name`` or its lazy ``_WHERE``) that are also
    the name of one of its submodules, from another module: importing that submodule (as
    any module that uses it does) replaces the package's attribute with the module, so
    ``from package import name`` gives the function or the module by the order of imports."""
    out = []
    for package, path in pkg.files.items():
        if path.name != "__init__.py":
            continue
        submodules = {m.rsplit(".", 1)[1] for m in pkg.files
                      if m.startswith(package + ".") and "." not in m[len(package) + 1:]}
        for node in ast.walk(pkg.trees[package]):
            names = [a.name for a in node.names] if isinstance(node, ast.ImportFrom) \
                and node.module else \
                [k.value for k in node.keys if isinstance(k, ast.Constant)] \
                if isinstance(node, ast.Dict) else []
            for name in names:
                if name in submodules and pkg._defined_in(package, name) != f"{package}.{name}":
                    out.append(f"{package} exports {name} from "
                               f"{pkg._defined_in(package, name)}, the name of its submodule "
                               f"{package}.{name}")
    return sorted(set(out))


def long_modules(pkg: Package, limit: int = MAX_LINES) -> list[str]:
    return sorted(f"{path.relative_to(pkg.root)}: {n} lines" for path in pkg.files.values()
                  if (n := len(path.read_text(encoding="utf-8").splitlines())) > limit)


# ------------------------------------------------------------------ on tracecheck itself


@pytest.fixture(scope="module")
def tracecheck() -> Package:
    return Package(ROOT, "tracecheck")


def test_no_import_cycle_between_modules(tracecheck):
    problems = module_cycles(tracecheck)
    assert not problems, "import cycles (imports inside functions count):\n" + "\n".join(problems)


def test_the_packages_form_a_dag(tracecheck):
    problems = package_cycles(tracecheck)
    assert not problems, "\n".join(problems)


def test_no_package_imports_one_above_it(tracecheck):
    problems = upward_imports(tracecheck)
    assert not problems, f"the order is {' < '.join(ORDER)}:\n" + "\n".join(problems)


def test_no_private_name_is_imported_from_another_module(tracecheck):
    problems = private_imports(tracecheck)
    assert not problems, "make the name public or move it:\n" + "\n".join(problems)


def test_no_package_exports_a_name_its_submodule_has(tracecheck):
    problems = shadowed_names(tracecheck)
    assert not problems, "rename the submodule:\n" + "\n".join(problems)


def lazy_faces(pkg: Package) -> list[str]:
    """Packages with lazy names (``_WHERE``): each name is in ``__all__`` and imported under
    ``if TYPE_CHECKING:`` from the module ``_WHERE`` names, so that editors and type checkers
    see what the package has; and nothing else is."""
    out = []
    for package, path in pkg.files.items():
        tree = pkg.trees[package]
        where = next((ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                      and getattr(n.targets[0], "id", None) == "_WHERE"), None)
        if path.name != "__init__.py" or where is None:
            continue
        names = next((set(ast.literal_eval(n.value)) for n in tree.body
                      if isinstance(n, ast.Assign)
                      and getattr(n.targets[0], "id", None) == "__all__"), set())
        typed = {a.name: f"{n.module}" for block in tree.body if isinstance(block, ast.If)
                 and getattr(block.test, "id", None) == "TYPE_CHECKING"
                 for n in block.body if isinstance(n, ast.ImportFrom) for a in n.names}
        if names != set(where):
            out.append(f"{package}: __all__ and _WHERE differ: {sorted(names ^ set(where))}")
        if typed != where:
            out.append(f"{package}: the TYPE_CHECKING imports and _WHERE differ: "
                       f"{sorted(set(typed.items()) ^ set(where.items()))}")
    return out


def test_lazy_names_are_visible_to_editors(tracecheck):
    problems = lazy_faces(tracecheck)
    assert not problems, "\n".join(problems)


def test_no_module_is_over_650_lines(tracecheck):
    problems = long_modules(tracecheck)
    assert not problems, "split these on the seams they mark:\n" + "\n".join(problems)


def environment_names(root: Path = ROOT) -> set[str]:
    """The names of tracecheck's own environments, read from their entry points in
    ``pyproject.toml``: each name, its first word (``highway`` of ``highway-continuous``)
    and its spelling with an underscore (``highway_continuous``)."""
    import tomllib

    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    names = set(project["entry-points"]["tracecheck.environments"])
    return names | {n.split("-")[0] for n in names} | {n.replace("-", "_") for n in names}


def environment_mentions(root: Path, package: str = "tracecheck",
                         allowed: str = "live/envs/") -> list[str]:
    """Where a file of ``package`` outside ``allowed`` names one of the environments (in
    code, strings, comments or docstrings; any case; 'frozen lake' spelled apart too)."""
    import re

    names = environment_names(ROOT)
    pattern = re.compile("|".join(
        re.escape(n).replace("lake", r"\s*lake").replace("walking", r"\s*walking")
        .replace("lander", r"\s*lander") for n in sorted(names, key=len, reverse=True)),
        re.IGNORECASE)
    found = []
    for path in sorted((root / package).rglob("*")):
        relative = path.relative_to(root / package).as_posix()
        if not path.is_file() or relative.startswith(allowed) or path.suffix in (".pyc",):
            continue
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            hit = pattern.search(line)
            if hit:
                found.append(f"{package}/{relative}:{number}: {hit.group(0)!r}")
    return found


def test_no_environment_is_named_outside_its_adapters():
    """An environment is one module under live/envs/ and its entry point: nothing else in
    tracecheck/ names one (no default, no registry, no help text, no example)."""
    problems = environment_mentions(ROOT)
    assert not problems, "name no environment outside tracecheck/live/envs/:\n" + \
        "\n".join(problems[:30])


def test_the_environment_check_finds_a_name(tmp_path):
    (tmp_path / "pkg" / "live" / "envs").mkdir(parents=True)
    (tmp_path / "pkg" / "stats.py").write_text('DEFAULT = "highway"\n# a Frozen Lake map\n')
    (tmp_path / "pkg" / "live" / "envs" / "highway.py").write_text('name = "highway"\n')
    assert environment_mentions(tmp_path, "pkg") == ["pkg/stats.py:1: 'highway'",
                                                     "pkg/stats.py:2: 'Frozen Lake'"]


#: a format chosen anywhere but the one emitter (render/emit.py) and the option's own parsing
_FORMAT_CHOICE = r"OutputFormat\.(json|md|csv)\b|\bfmt\s*[!=]=\s*[\"'](json|md|csv)[\"']"


def format_choices(root: Path, package: str = "tracecheck",
                   allowed: tuple[str, ...] = ("render/emit.py", "cli/common.py")) -> list[str]:
    """Where a module other than the emitter picks what to print by the output format."""
    import re

    found = []
    for path in sorted((root / package).rglob("*.py")):
        relative = path.relative_to(root / package).as_posix()
        if relative in allowed:
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if re.search(_FORMAT_CHOICE, line):
                found.append(f"{package}/{relative}:{number}: {line.strip()}")
    return found


def test_one_emitter_writes_every_format():
    """Every command hands a Report to render.emit.emit, which alone chooses by --format
    (seven commands dispatched by hand)."""
    problems = format_choices(ROOT)
    assert not problems, "use tracecheck.render.emit.emit:\n" + "\n".join(problems)


#: another package's name-mangled private attributes (``_Writer__finalize_chunk``) allowed,
#: by file, with why: none (tracecheck writes MCAP with its own writer over mcap's public
#: record classes)
MANGLED_ALLOWED: dict[str, set[str]] = {}


def mangled_names(root: Path, package: str = "tracecheck") -> list[str]:
    """Uses of another class's name-mangled private attributes, outside the allowed ones."""
    import re

    found = []
    for path in sorted((root / package).rglob("*.py")):
        relative = f"{package}/{path.relative_to(root / package).as_posix()}"
        for number, line in enumerate(path.read_text().splitlines(), 1):
            for name in re.findall(r"\b_[A-Z][A-Za-z0-9]*__[a-z][a-z0-9_]*", line):
                if name not in MANGLED_ALLOWED.get(relative, set()):
                    found.append(f"{relative}:{number}: {name}")
    return found


def test_no_private_attribute_of_another_package():
    problems = mangled_names(ROOT)
    assert not problems, "use the package's public API:\n" + "\n".join(problems)


def test_the_format_and_private_checks_find_what_they_look_for(tmp_path):
    (tmp_path / "pkg" / "cli").mkdir(parents=True)
    (tmp_path / "pkg" / "cli" / "x.py").write_text(
        "if fmt == OutputFormat.csv:\n    pass\nw._Writer__finalize_chunk()\n"
        "if fmt == 'md':\n    pass\n")
    assert format_choices(tmp_path, "pkg") == [
        "pkg/cli/x.py:1: if fmt == OutputFormat.csv:", "pkg/cli/x.py:4: if fmt == 'md':"]
    assert mangled_names(tmp_path, "pkg") == ["pkg/cli/x.py:3: _Writer__finalize_chunk"]


def imports_of_test_modules(pkg: Package) -> list[str]:
    """Imports of a test module or a conftest (shared code belongs in a helper module)."""
    return sorted({f"{i.source} imports {i.target} ({pkg.where(i)})" for i in pkg.imports
                   if i.source != i.target
                   and pkg.files[i.target].name.startswith(("test_", "conftest"))})


def test_no_test_module_imports_another():
    """Shared test code lives in tests/helpers.py (and helper modules such as
    tests/live/toy.py), fixtures in conftest.py: a test module or conftest is never imported."""
    problems = imports_of_test_modules(Package(ROOT, "tests"))
    assert not problems, "\n".join(problems)


# ------------------------------------------------------------------ the checks can fail


def _package(tmp_path: Path, files: dict[str, str]) -> Package:
    for name, text in files.items():
        path = tmp_path / "fake" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return Package(tmp_path, "fake")


def test_the_checks_find_what_they_look_for(tmp_path):
    pkg = _package(tmp_path, {
        "__init__.py": "",
        "errors.py": "class Oops(Exception):\n    pass\n",
        "low/__init__.py": '_WHERE = {"helper": "tools", "other": "tools"}\n',
        "low/tools.py": """\
            from ..errors import Oops

            def helper():
                from ..high.view import show  # inside a function: counts
                return show, Oops
            """,
        "low/other.py": "from fake.low import helper\nfrom .tools import _secret\n",
        "high/__init__.py": "from .view import show\n",
        "high/view.py": "from ..low.other import helper\n\ndef show():\n    pass\n"
                        + "x = 1\n" * 20,
    })
    order = ("top", "low", "high")
    assert module_cycles(pkg) == [
        "cycle fake.high.view <-> fake.low.other <-> fake.low.tools:\n"
        "    fake.high.view -> fake.low.other (fake/high/view.py:1)\n"
        "    fake.low.other -> fake.low.tools (fake/low/other.py:1)\n"
        "    fake.low.other -> fake.low.tools (fake/low/other.py:2)\n"
        "    fake.low.tools -> fake.high.view (fake/low/tools.py:4)"]
    assert package_cycles(pkg) == [
        "packages high <-> low on a cycle:\n"
        "    high -> low: fake.high.view -> fake.low.other (fake/high/view.py:1)\n"
        "    low -> high: fake.low.tools -> fake.high.view (fake/low/tools.py:4)"]
    assert "and 1 more" in package_cycles(_package(tmp_path / "twice", {
        "__init__.py": "", "a/__init__.py": "", "b/__init__.py": "",
        "a/x.py": "from ..b import y\nfrom ..b.y import f, g\n",
        "b/y.py": "from ..a import x\n"}))[0]
    assert upward_imports(pkg, order) == [
        "low imports high, which comes after it: fake.low.tools -> fake.high.view "
        "(fake/low/tools.py:4)"]
    assert upward_imports(pkg, ("top", "low")) == [
        "package high (fake.high) has no place in the order ('top', 'low')",
        "package high (fake.high.view) has no place in the order ('top', 'low')"]
    assert private_imports(pkg) == [
        "fake.low.other imports _secret from fake.low.tools (fake/low/other.py:2)"]
    assert lazy_faces(pkg) == [
        "fake.low: __all__ and _WHERE differ: ['helper', 'other']",
        "fake.low: the TYPE_CHECKING imports and _WHERE differ: [('helper', 'tools'), "
        "('other', 'tools')]"]
    assert shadowed_names(pkg) == [
        "fake.low exports other from fake.low.tools, the name of its submodule fake.low.other"]
    assert long_modules(pkg, limit=20) == ["fake/high/view.py: 24 lines"]
    assert long_modules(pkg) == []


def test_the_test_check_finds_a_test_module_imported(tmp_path):
    pkg = _package(tmp_path, {"conftest.py": "from fake.helpers import run\n",
                              "helpers.py": "def run():\n    pass\n",
                              "b/test_one.py": "from fake.helpers import run\n",
                              "b/test_two.py": "def test():\n    from fake.b.test_one import x\n",
                              "c/test_three.py": "from fake.conftest import ROOT\n"})
    assert imports_of_test_modules(pkg) == [
        "fake.b.test_two imports fake.b.test_one (fake/b/test_two.py:2)",
        "fake.c.test_three imports fake.conftest (fake/c/test_three.py:1)"]


def test_the_checks_pass_a_clean_package(tmp_path):
    pkg = _package(tmp_path, {
        "__init__.py": "",
        "errors.py": "",
        "low/__init__.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                           "    from .tools import helper\n"
                           "_WHERE = {'helper': 'tools'}\n__all__ = ['helper']\n",
        "low/tools.py": "from .. import errors\n\ndef helper():\n    from ..errors import Oops\n",
        "high/__init__.py": "",
        "high/view.py": "import fake.low.tools\nfrom fake.low import helper\n",
    })
    assert pkg.imports  # the imports were seen …
    assert {(i.source, i.target) for i in pkg.imports} >= {
        ("fake.low.tools", "fake.errors"), ("fake.high.view", "fake.low.tools")}
    order = ("top", "low", "high")  # … and none breaks a rule
    assert (module_cycles(pkg), package_cycles(pkg), upward_imports(pkg, order),
            private_imports(pkg), shadowed_names(pkg), lazy_faces(pkg)) == ([],) * 6

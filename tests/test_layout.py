"""The stage layout (docs/architecture.md): imports go one way and never in a circle, one concept per module, the API stays whole."""

import ast
import builtins
import re
from pathlib import Path

import pytest

import fts_calib

PACKAGE = Path(fts_calib.__file__).resolve().parent
#: The contributors' reference of the layout: its stages and every module's concept.
ARCHITECTURE = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
#: The stages in import order: a stage imports only from stages before it (docs/architecture.md).
STAGES = (
    *("core", "model", "robot", "sources", "filters", "budget", "session"),
    *("planning", "payload", "service", "monitor", "sim", "report", "app"),
)
#: A module holds one concept: a few hundred lines at most. Split a file by meaning when it outgrows its concept,
#: never to stay under a count (400 split concepts across files: a session over seven, a bag reader over four).
MAX_LINES = 800


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _dotted(path: Path) -> str:
    parts = ("fts_calib", *path.relative_to(PACKAGE).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> list[tuple[int, str]]:
    """Every fts_calib module that ``path`` imports, at any depth (lazy imports included)."""
    return _imports_of(path.read_text(encoding="utf-8"), _dotted(path), path.name == "__init__.py")


def _imports_of(source: str, dotted: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, module) of every fts_calib import in ``source``, the text of module ``dotted``."""
    tree = ast.parse(source)
    here = dotted.split(".")
    package = here if is_package else here[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [target] if node.module else [f"{target}.{a.name}" for a in node.names]
            found += [(node.lineno, n) for n in names]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
    return [(line, name) for line, name in found if name == "fts_calib" or name.startswith("fts_calib.")]


def _stage(dotted: str) -> str | None:
    parts = dotted.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in STAGES else None


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while True:
                w = stack.pop()
                part.append(w)
                if w == v:
                    break
            if len(part) > 1:
                found.append(sorted(part))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def _module_of(name: str, modules: set[str]) -> str | None:
    """The module an imported dotted name lives in (``fts_calib.a.b.Name`` -> ``fts_calib.a.b``), or None."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def test_no_module_imports_itself_through_others_not_even_lazily_or_for_typing():
    """Every import counts (top level, inside functions, under TYPE_CHECKING): a circle means one concept split apart."""
    modules = {_dotted(p) for p in _modules()}
    edges = {
        _dotted(p): {m for _, name in _imports(p) if (m := _module_of(name, modules)) is not None and m != _dotted(p)} for p in _modules()
    }
    edges = {m: {d for d in deps if d != "fts_calib"} for m, deps in edges.items() if m != "fts_calib"}
    assert not _cycles(edges), f"import circles: {_cycles(edges)}"
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]  # the checker sees one


def test_every_module_lives_in_a_stage():
    loose = [p.name for p in PACKAGE.glob("*.py") if p.name not in ("__init__.py", "_version.py")]
    assert not loose, f"modules outside the stage folders {STAGES}: {loose}"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_go_one_way(path):
    stage = _stage(_dotted(path))
    if stage is None:  # fts_calib/__init__.py re-exports the public API; _version.py imports nothing
        return
    rank = STAGES.index(stage)
    against = []
    for line, name in _imports(path):
        if name == "fts_calib._version":
            continue
        target = _stage(name)
        if target is None or STAGES.index(target) > rank:  # None: the package root, which imports every stage
            against.append(f"line {line}: {stage} imports {name}")
    assert not against, f"{path.relative_to(PACKAGE)} imports against the order {' <- '.join(STAGES)}:\n" + "\n".join(against)


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_a_module_is_a_few_hundred_lines_at_most(path):
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(PACKAGE)} has {lines} lines (at most {MAX_LINES}): split it by concept"


def test_the_checker_sees_imports_against_the_order_even_lazy_and_relative():
    source = "from ..app import cli\n\ndef f():\n    from ..sim.sensor import SimulatedSensor\n    from . import sensor\n"
    found = _imports_of(source, "fts_calib.model.estimator", is_package=False)
    assert [name for _, name in found] == ["fts_calib.app", "fts_calib.sim.sensor", "fts_calib.model.sensor"]
    assert [_stage(name) for _, name in found] == ["app", "sim", "model"]


def _exception_classes(tree: ast.AST, known: set[str]) -> list[tuple[int, str]]:
    """(line, name) of the classes in ``tree`` that derive from a builtin exception or from one of ``known``."""
    builtin = {name for name, value in vars(builtins).items() if isinstance(value, type) and issubclass(value, BaseException)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            bases = {b.id if isinstance(b, ast.Name) else b.attr if isinstance(b, ast.Attribute) else "" for b in node.bases}
            if bases & (builtin | known):
                found.append((node.lineno, node.name))
    return found


def test_every_exception_lives_in_core_exceptions():
    """core/ holds the exceptions, all of them (docs/architecture.md); the package exports the ones a caller catches (at most 40 names)."""
    home = PACKAGE / "core" / "exceptions.py"
    defined = {name for _, name in _exception_classes(ast.parse(home.read_text(encoding="utf-8")), set())}
    assert {"FtsCalibError", "FtsCalibWarning", "ConfigError"} <= defined
    elsewhere = [
        f"{path.relative_to(PACKAGE)}:{line}: {name}"
        for path in _modules()
        if path != home
        for line, name in _exception_classes(ast.parse(path.read_text(encoding="utf-8")), defined)
    ]
    assert not elsewhere, "exception classes outside core/exceptions.py:\n" + "\n".join(elsewhere)
    exported = {name for name in fts_calib.__all__ if name in defined}
    assert {"FtsCalibError", "FtsCalibWarning", "ShapeError", "ConfigError", "FileFormatError", "RecordingError"} <= exported
    assert len(fts_calib.__all__) <= 40, f"{len(fts_calib.__all__)} names in fts_calib.__all__: at most 40 (the rest: from their stage)"


def test_the_architecture_page_lists_the_stages_in_order_and_every_module():
    """docs/architecture.md stays the layout's reference: its stage table in import order, one row per module, no row for a gone one."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    assert " ← ".join(STAGES) in text, "the import order line"
    overview = text[text.index("## Stages in import order") : text.index("## Modules")]
    assert re.findall(r"^\| `(\w+)` \| ", overview, flags=re.M) == list(STAGES), "the stage table, in import order"
    listed = re.findall(r"^\| `(\w+/\w+\.py)` \| ", text, flags=re.M)
    modules = {p.relative_to(PACKAGE).as_posix() for p in _modules() if p.parent != PACKAGE and p.name != "__init__.py"}
    assert len(listed) == len(set(listed)), "a module listed twice"
    assert not modules - set(listed), f"modules docs/architecture.md does not list: {sorted(modules - set(listed))}"
    assert not set(listed) - modules, f"docs/architecture.md lists modules that do not exist: {sorted(set(listed) - modules)}"


def _stage_imports() -> dict[str, set[str]]:
    """Per stage, the other stages and the modules of them (``stage/module.py``) its modules import."""
    modules = {_dotted(p) for p in _modules()}
    found: dict[str, set[str]] = {stage: set() for stage in STAGES}
    for path in _modules():
        stage = _stage(_dotted(path))
        for _, name in _imports(path) if stage else ():
            target = _module_of(name, modules)
            if target and (other := _stage(target)) and other != stage:
                parts = target.split(".")[1:]  # a stage's package itself (its __init__) names the stage alone
                found[stage] |= {other} | ({"/".join(parts) + ".py"} if len(parts) > 1 else set())
    return found


def test_the_architecture_page_says_what_each_stage_imports():
    """The 'imports from' column names each stage imported, whole (`robot`) or the modules of it imported (`robot/tool.py`)."""
    overview = ARCHITECTURE.read_text(encoding="utf-8")
    overview = overview[overview.index("## Stages in import order") : overview.index("## Modules")]
    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| `(\w+)` \|[^|]*\| ([^|]*) \|", overview, flags=re.M)}
    wrong = []
    for stage, imported in _stage_imports().items():
        said = rows[stage]
        before = set(STAGES[: STAGES.index(stage)])
        if said.startswith("every stage before it"):
            names = before
        elif said.startswith("everything"):
            names = set(STAGES) - {stage}
        else:
            names = set(re.findall(r"`([\w/.]+)`", said))
        stages = {n for n in imported if "/" not in n}
        whole = {n for n in names if "/" not in n}
        partly = {n.split("/")[0] for n in names if "/" in n}
        if stages != whole | partly:
            wrong.append(f"{stage} imports {sorted(stages)}, the page says {said!r}")
        for stage_named in partly:
            modules = {n for n in imported if n.startswith(stage_named + "/")}
            if not modules <= names:
                wrong.append(f"{stage} imports {sorted(modules)} of {stage_named}, the page says {said!r}")
    assert not wrong, "docs/architecture.md, the stage table's 'imports from':\n" + "\n".join(wrong)

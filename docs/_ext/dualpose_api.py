"""Sphinx extension of the dualpose site: the API pages and the offline cross-reference inventories.

The API reference is generated at every build from the package itself: every public module under
``src/dualpose`` (a name without a leading underscore, outside the ``cli`` package, which only parses and prints)
gets one page, ``api/<module>.rst``, that documents the names in its ``__all__``.  A name a module re-exports from
another public module is listed with a link to the page that documents it, so each object is described once, where
it is defined.  New modules appear without editing the docs.

Cross-links to Python, NumPy and SciPy go through intersphinx, but this site is built without a network: the
inventories (``objects.inv``) are written here, from the table :data:`EXTERNAL`, for the handful of outside names
the signatures and docstrings refer to, with the public URLs of those projects' documentation.
"""

from __future__ import annotations

import importlib
import inspect
import os
import zlib
from pathlib import Path

#: subpackages the API reference leaves out: the command line (documented by ``dualpose --help``)
EXCLUDED = ("dualpose.cli",)

#: the layouts, units and frames, shown at the top of every API page
CONVENTIONS = """\
.. admonition:: Layouts, units and frames
   :class: dualpose-conventions

   Quaternions are ``(..., 4)`` float64 arrays ``[x, y, z, w]`` (scalar last, Hamilton product, active rotation
   ``v' = q ⊗ v ⊗ q*``); dual quaternions are ``(..., 8)`` arrays ``[real xyzw, dual xyzw]`` with
   ``dual = ½ t ⊗ real``; twists are ``(..., 6)`` arrays ``[ω, v]``.  Every function broadcasts over leading axes.
   Units are SI (m, s, rad, m/s², rad/s) unless a name says otherwise (``_deg``, ``_ns``).  A pose maps body
   coordinates to world coordinates (``p_world = R p_body + t``).  Details: :doc:`/conventions`.
"""

# --------------------------------------------------------------------------------------------- the API pages


def public_modules(package_dir: Path, package: str = "dualpose") -> list[str]:
    """Every public module below ``package_dir`` (packages with or without ``__init__.py``), sorted."""
    names = [package]
    for root, dirs, files in os.walk(package_dir):
        dirs[:] = sorted(d for d in dirs if not d.startswith(("_", ".")) and d != "__pycache__")
        rel = Path(root).relative_to(package_dir).parts
        prefix = ".".join((package, *rel))
        if rel:
            names.append(prefix)
        names += [f"{prefix}.{f[:-3]}" for f in files if f.endswith(".py") and not f.startswith("_")]
    return sorted(n for n in set(names) if not n.startswith(EXCLUDED))


def _title(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def _defining_module(obj: object) -> str | None:
    return getattr(obj, "__module__", None) if (inspect.isclass(obj) or inspect.isfunction(obj)) else None


def _ufunc_entry(qualified: str, obj) -> str:
    """A NumPy ufunc as a function entry (autodoc cannot read a ufunc's signature): signature and help text."""
    args = ["x"] if obj.nin == 1 else [f"x{i + 1}" for i in range(obj.nin)]
    text = (obj.__doc__ or "").split("\n\n", 1)[-1].strip()
    body = "\n".join(f"   {line}" for line in text.splitlines())
    return f".. py:function:: {qualified}({', '.join(args)}, /, out=None, **kwargs)\n\n{body}\n"


def _class_entry(modname: str, name: str, cls: type) -> str:
    """A class with its members, also those it inherits from dualpose bases (private bases are not documented)."""
    foreign = [b for b in cls.__mro__[1:] if not b.__module__.startswith("dualpose")]
    bases = list(cls.__bases__)
    public_bases(None, "", cls, None, bases)
    # "Bases: object" says nothing: the line is shown for classes with a real base only
    options = "   :members:\n" + ("   :show-inheritance:\n" if [b for b in bases if b is not object] else "")
    if any(b.__module__.startswith("dualpose") for b in cls.__mro__[1:]):
        options += f"   :inherited-members: {', '.join(b.__name__ for b in foreign)}\n"
    return f".. autoclass:: {modname}.{name}\n{options}"


def _data_entry(modname: str, name: str, obj: object, attr_docs: dict) -> str:
    """A module constant: autodoc when the source documents it (``#:`` comment or string), else its value only.

    autodoc would otherwise show the docstring of the value's type (all of :class:`numpy.ndarray`'s, say).
    """
    value = "" if len(repr(obj)) <= 80 else "   :no-value:\n"
    if ("", name) in attr_docs:
        return f".. autodata:: {modname}.{name}\n{value}"
    shown = "" if value else f"   :value: {' '.join(repr(obj).split())}\n"
    return f".. py:data:: {name}\n{shown}"


def _summary(obj: object, attr_docs: dict | None = None, name: str = "") -> str:
    """The first paragraph of an object's docstring on one line (a ufunc's after its signature line)."""
    import numpy as np

    if attr_docs is not None and ("", name) in attr_docs:
        doc = "\n".join(attr_docs["", name])
    elif isinstance(obj, np.ufunc):
        doc = (obj.__doc__ or "").split("\n\n", 1)[-1]
    elif inspect.ismodule(obj) or inspect.isclass(obj) or callable(obj):
        doc = inspect.getdoc(obj) or ""
    else:
        doc = ""
    return " ".join(doc.strip().split("\n\n", 1)[0].split())


def _table(rows: list[tuple[str, str]]) -> list[str]:
    """A two-column summary table (a reference, the summary); autosummary would cut summaries at "eq."."""
    out = [".. list-table::\n   :widths: 30 70\n   :class: dualpose-summary\n"]
    out += [f"   * - {ref}\n     - {text or ' '}" for ref, text in rows]
    return [*out, ""]


def _role(obj: object) -> str:
    if inspect.ismodule(obj):
        return "mod"
    if inspect.isclass(obj):
        return "class"
    return "func" if callable(obj) else "data"


def _defined_below(obj: object, modname: str, documented: set[str]) -> str | None:
    """The documented module below the package ``modname`` whose ``__all__`` holds this very constant."""
    for other in sorted(documented, key=len, reverse=True):
        if other.startswith(modname + "."):
            mod = importlib.import_module(other)
            if any(getattr(mod, n, None) is obj for n in getattr(mod, "__all__", [])):
                return other
    return None


def module_page(modname: str, documented: set[str]) -> str:
    """The reStructuredText of one module's page."""
    import numpy as np
    from sphinx.pycode import ModuleAnalyzer

    mod = importlib.import_module(modname)
    try:
        attr_docs = ModuleAnalyzer.for_module(modname).find_attr_docs()
    except Exception:  # a namespace package has no source to analyse
        attr_docs = {}
    names = list(getattr(mod, "__all__", []))
    own, elsewhere, submodules = [], [], []
    for name in names:
        obj = getattr(mod, name)
        if inspect.ismodule(obj):
            submodules.append(obj.__name__)
            continue
        where = _defining_module(obj)
        if where is None and hasattr(mod, "__path__") and not isinstance(obj, np.ufunc):
            where = _defined_below(obj, modname, documented)
        if where and where != modname and where in documented:
            elsewhere.append((f"{where}.{name}", obj))
        else:
            own.append((name, obj))
    lines = [_title(modname), CONVENTIONS, f".. automodule:: {modname}\n   :no-members:\n"]
    children = sorted(m for m in documented if m.rpartition(".")[0] == modname)
    children += [m for m in submodules if m not in children]
    if children:
        rows = [(f":mod:`{m}`", _summary(importlib.import_module(m))) for m in children]
        lines += [".. rubric:: Modules\n", *_table(rows)]
    if elsewhere:
        rows = [(f":{_role(o)}:`~{target}`", _summary(o)) for target, o in elsewhere]
        lines += [".. rubric:: Re-exported here (documented where they are defined)\n", *_table(rows)]
    if own:
        rows = [(f":{_role(o)}:`{n}`", _summary(o, attr_docs, n)) for n, o in own]
        lines += [".. rubric:: Summary\n", *_table(rows)]
        for kind, test in (("Classes", inspect.isclass), ("Functions", callable), ("Data", lambda o: True)):
            group = [(n, o) for n, o in own if test(o)]
            own = [(n, o) for n, o in own if not test(o)]
            if not group:
                continue
            lines.append(_title(kind, "-"))
            for name, obj in group:
                if kind == "Classes":
                    lines.append(_class_entry(modname, name, obj))
                elif isinstance(obj, np.ufunc):
                    lines.append(_ufunc_entry(name, obj))
                elif kind == "Functions":
                    lines.append(f".. autofunction:: {modname}.{name}\n")
                else:
                    lines.append(_data_entry(modname, name, obj, attr_docs))
    return "\n".join(lines)


def index_page(modules: list[str]) -> str:
    """The API index: one table per top-level folder, and the hidden tree every page hangs from."""
    groups: dict[str, list[str]] = {}
    for m in modules:
        top = ".".join(m.split(".")[:2])
        groups.setdefault(top, []).append(m)
    lines = [
        _title("API reference"),
        "Every public module of ``dualpose``, generated from its docstrings.  The folders are layers that import only "
        "downwards (:doc:`/architecture`); ``import dualpose`` gives the algebra, the other folders load when "
        "imported (``import dualpose.registration as reg``).\n",
        "The command line, every subcommand and option: :doc:`cli`.\n",
        CONVENTIONS,
        ".. toctree::\n   :hidden:\n\n   cli\n" + "\n".join(f"   {m}" for m in modules) + "\n",
    ]
    for top, mods in groups.items():
        rows = [(f":mod:`{m}`", _summary(importlib.import_module(m))) for m in mods]
        lines += [_title(f"``{top}``", "-"), *_table(rows)]
    return "\n".join(lines)


def cli_page() -> str:
    """The ``dualpose`` command's help, every subcommand (and theirs) in turn, from the parser itself."""
    import argparse

    from dualpose.cli.main import build_parser

    def sections(parser: argparse.ArgumentParser, level: str) -> list[str]:
        help_text = "\n".join(f"   {line}".rstrip() for line in parser.format_help().splitlines())
        out = [_title(parser.prog, level), ".. code-block:: text\n", help_text, ""]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    out += sections(sub, "-" if parser.prog == "dualpose" else "~")
        return out

    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "80"  # argparse wraps to the terminal: one width for every build
    try:
        parser = build_parser()
        lines = [
            _title("Command line"),
            "The ``dualpose`` command and every subcommand's options, generated from the command's own parser "
            "(``dualpose.cli`` parses and prints; the work is done by the functions of the API reference).\n",
            *sections(parser, "-"),
        ]
    finally:
        if saved is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = saved
    return "\n".join(lines)


def write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` unless the file already holds it (Sphinx then rereads only what changed)."""
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def generate_api(app) -> None:
    """``builder-inited``: write ``api/*.rst`` for every public module and remove pages of vanished modules."""
    import dualpose

    out = Path(app.srcdir) / "api"
    out.mkdir(exist_ok=True)
    modules = public_modules(Path(dualpose.__file__).parent)
    documented = set(modules)
    pages = {f"{m}.rst": module_page(m, documented) for m in modules}
    pages["index.rst"] = index_page(modules)
    pages["cli.rst"] = cli_page()
    for name, text in pages.items():
        write_if_changed(out / name, text)
    for stale in out.glob("*.rst"):
        if stale.name not in pages:
            stale.unlink()


# ------------------------------------------------------------------------------------ offline inventories

_NP = "https://numpy.org/doc/stable/"
_SP = "https://docs.scipy.org/doc/scipy/"
_PY = "https://docs.python.org/3/"
_MPL = "https://matplotlib.org/stable/"
_DASK = "https://distributed.dask.org/en/stable/"

#: project -> (base URL, [(name, role, relative URI[, title])]) of the outside names the docs refer to
EXTERNAL: dict[str, tuple[str, list[tuple[str, ...]]]] = {
    "python": (_PY, [
        *[(n, "py:class", f"library/functions.html#{n}") for n in ("float", "int", "bool", "object", "type", "slice")],
        *[(n, "py:class", f"library/stdtypes.html#{n}") for n in ("str", "bytes", "tuple", "list", "dict", "set")],
        *[(n, "py:exception", f"library/exceptions.html#{n}") for n in
          ("ValueError", "TypeError", "RuntimeError", "OSError", "FileNotFoundError", "FileExistsError",
           "KeyError", "IndexError", "UserWarning", "RuntimeWarning", "Warning", "EOFError")],
        ("None", "py:data", "library/constants.html#None"),
        ("callable", "py:function", "library/functions.html#callable"),
        ("bltin-boolean-values", "std:label", "library/stdtypes.html#bltin-boolean-values", "Boolean Values"),
        *[(t, "std:term", f"glossary.html#term-{t.replace(' ', '-')}") for t in
          ("iterable", "sequence", "generator", "generic type", "mapping", "file object", "path-like object",
           "hashable", "context manager", "named tuple")],
        ("True", "py:data", "library/constants.html#True"),
        ("False", "py:data", "library/constants.html#False"),
        ("NotImplemented", "py:data", "library/constants.html#NotImplemented"),
        ("pathlib.Path", "py:class", "library/pathlib.html#pathlib.Path"),
        ("pathlib.PurePath", "py:class", "library/pathlib.html#pathlib.PurePath"),
        ("os.PathLike", "py:class", "library/os.html#os.PathLike"),
        ("io.TextIOBase", "py:class", "library/io.html#io.TextIOBase"),
        ("typing.TextIO", "py:class", "library/typing.html#typing.TextIO"),
        ("typing.IO", "py:class", "library/typing.html#typing.IO"),
        ("typing.Any", "py:data", "library/typing.html#typing.Any"),
        ("typing.Literal", "py:data", "library/typing.html#typing.Literal"),
        ("typing.Optional", "py:data", "library/typing.html#typing.Optional"),
        ("typing.Union", "py:data", "library/typing.html#typing.Union"),
        ("typing.ClassVar", "py:data", "library/typing.html#typing.ClassVar"),
        ("typing.Protocol", "py:class", "library/typing.html#typing.Protocol"),
        ("typing.NamedTuple", "py:class", "library/typing.html#typing.NamedTuple"),
        ("typing.Self", "py:data", "library/typing.html#typing.Self"),
        *[(f"collections.abc.{n}", "py:class", f"library/collections.abc.html#collections.abc.{n}") for n in
          ("Callable", "Iterable", "Iterator", "Sequence", "Mapping", "MutableMapping", "Generator", "Hashable")],
        ("abc.ABC", "py:class", "library/abc.html#abc.ABC"),
        ("fractions.Fraction", "py:class", "library/fractions.html#fractions.Fraction"),
        ("enum.Enum", "py:class", "library/enum.html#enum.Enum"),
        ("enum.IntEnum", "py:class", "library/enum.html#enum.IntEnum"),
        ("datetime.datetime", "py:class", "library/datetime.html#datetime.datetime"),
        ("concurrent.futures.Executor", "py:class", "library/concurrent.futures.html#concurrent.futures.Executor"),
    ]),
    "numpy": (_NP, [
        ("numpy", "py:module", "reference/index.html"),
        ("numpy.ndarray", "py:class", "reference/generated/numpy.ndarray.html"),
        ("numpy.dtype", "py:class", "reference/generated/numpy.dtype.html"),
        ("numpy.float64", "py:class", "reference/arrays.scalars.html#numpy.float64"),
        ("numpy.floating", "py:class", "reference/arrays.scalars.html#numpy.floating"),
        ("numpy.integer", "py:class", "reference/arrays.scalars.html#numpy.integer"),
        ("numpy.bool", "py:class", "reference/arrays.scalars.html#numpy.bool"),
        ("numpy.ufunc", "py:class", "reference/generated/numpy.ufunc.html"),
        ("numpy.random.Generator", "py:class", "reference/random/generator.html#numpy.random.Generator"),
        ("numpy.random.default_rng", "py:function", "reference/random/generator.html#numpy.random.default_rng"),
        ("numpy.typing.ArrayLike", "py:data", "reference/typing.html#numpy.typing.ArrayLike"),
        ("numpy.typing.ArrayLike", "py:class", "reference/typing.html#numpy.typing.ArrayLike"),
        ("numpy.random._generator.Generator", "py:class", "reference/random/generator.html#numpy.random.Generator"),
        ("numpy.typing.NDArray", "py:data", "reference/typing.html#numpy.typing.NDArray"),
        ("numpy.typing.NDArray", "py:class", "reference/typing.html#numpy.typing.NDArray"),
        *[(f"numpy.{n}", "py:class", f"reference/arrays.scalars.html#numpy.{n}") for n in
          ("int64", "intp", "uint8", "uint32", "int32", "bool_", "generic", "number")],
        ("numpy.typing.DTypeLike", "py:data", "reference/typing.html#numpy.typing.DTypeLike"),
        *[(f"numpy.{n}", "py:function", f"reference/generated/numpy.{n}.html") for n in
          ("array", "asarray", "einsum", "linspace", "arctan2", "interp", "unwrap", "set_printoptions", "allclose",
           "save", "load", "savez", "genfromtxt", "loadtxt", "memmap")],
    ]),
    "scipy": (_SP, [
        ("scipy.spatial.transform.Rotation", "py:class",
         "reference/generated/scipy.spatial.transform.Rotation.html"),
        ("scipy.spatial.transform.RigidTransform", "py:class",
         "reference/generated/scipy.spatial.transform.RigidTransform.html"),
        ("scipy.spatial.transform.Slerp", "py:class", "reference/generated/scipy.spatial.transform.Slerp.html"),
        ("scipy.io.loadmat", "py:function", "reference/generated/scipy.io.loadmat.html"),
        ("scipy.optimize.least_squares", "py:function", "reference/generated/scipy.optimize.least_squares.html"),
        ("scipy.optimize.minimize_scalar", "py:function",
         "reference/generated/scipy.optimize.minimize_scalar.html"),
        ("scipy.signal.butter", "py:function", "reference/generated/scipy.signal.butter.html"),
        ("scipy.signal.sosfiltfilt", "py:function", "reference/generated/scipy.signal.sosfiltfilt.html"),
        ("scipy.interpolate.CubicSpline", "py:class", "reference/generated/scipy.interpolate.CubicSpline.html"),
        ("scipy.linalg.cho_factor", "py:function", "reference/generated/scipy.linalg.cho_factor.html"),
        ("scipy.linalg.expm", "py:function", "reference/generated/scipy.linalg.expm.html"),
    ]),
    "distributed": (_DASK, [
        ("distributed.LocalCluster", "py:class", "api.html#distributed.LocalCluster"),
        ("distributed.Client", "py:class", "api.html#distributed.Client"),
    ]),
    "matplotlib": (_MPL, [
        ("matplotlib.figure.Figure", "py:class", "api/_as_gen/matplotlib.figure.Figure.html"),
        ("matplotlib.axes.Axes", "py:class", "api/_as_gen/matplotlib.axes.Axes.html"),
    ]),
}


def inventory_bytes(project: str, entries: list[tuple[str, ...]]) -> bytes:
    """An ``objects.inv`` (Sphinx inventory version 2) holding ``entries``."""
    header = f"# Sphinx inventory version 2\n# Project: {project}\n# Version: \n"
    header += "# The remainder of this file is compressed using zlib.\n"
    body = "".join(f"{e[0]} {e[1]} 1 {e[2]} {e[3] if len(e) > 3 else '-'}\n" for e in entries)
    return header.encode() + zlib.compress(body.encode())


def write_inventories(directory: Path) -> dict[str, tuple[str, str]]:
    """Write one inventory per project of :data:`EXTERNAL`; the ``intersphinx_mapping`` that reads them."""
    directory.mkdir(parents=True, exist_ok=True)
    mapping = {}
    for project, (base, entries) in EXTERNAL.items():
        path = directory / f"{project}.inv"
        path.write_bytes(inventory_bytes(project, entries))
        mapping[project] = (base, str(path))
    return mapping


def canonical_target(target: str, modname: str | None) -> str | None:
    """The documented name of ``target`` when it names a dualpose object by another route, else None.

    ``dualpose.registration.register_pose`` (a re-export) becomes ``dualpose.registration.estimate.register_pose``;
    a bare ``register_pose`` is looked up in the module of the referring docstring, then in the public API, where it
    must be unique.
    """
    candidates = [target]
    if modname and "." not in target:
        candidates.append(f"{modname}.{target}")
    for name in candidates:
        obj = _lookup(name)
        if obj is not None:
            return _canonical_name(obj, name) or _documented_constant(obj, name)
    head, _, rest = target.partition(".")
    if head and not head.startswith("dualpose"):
        found = {_canonical_name(o, n) for n, o in _api_objects().items() if n.rpartition(".")[2] == head}
        found.discard(None)
        if len(found) == 1:
            return ".".join(filter(None, (found.pop(), rest)))
    return None


def _lookup(name: str) -> object | None:
    if not name.startswith("dualpose"):
        return None
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None
        return obj
    return None


def _canonical_name(obj: object, name: str) -> str | None:
    if isinstance(obj, property):
        obj = obj.fget
    owner = getattr(obj, "__module__", None)
    qualname = getattr(obj, "__qualname__", None)
    if inspect.ismodule(obj):
        return obj.__name__
    if owner and qualname and owner.startswith("dualpose") and not owner.startswith(EXCLUDED):
        return f"{owner}.{qualname}"
    return None


def _documented_constant(obj: object, name: str) -> str | None:
    """The deepest public module whose ``__all__`` holds this very constant under the same name."""
    last = name.rpartition(".")[2]
    found = [n for n, o in _api_objects().items() if o is obj and n.rpartition(".")[2] == last]
    return max(found, key=lambda n: n.count("."), default=None)


_CACHE: dict[str, object] = {}


def _api_objects() -> dict[str, object]:
    """Every name in the ``__all__`` of a public module, by its full dotted name (computed once)."""
    if not _CACHE:
        import dualpose

        for modname in public_modules(Path(dualpose.__file__).parent):
            mod = importlib.import_module(modname)
            for n in getattr(mod, "__all__", []):
                obj = getattr(mod, n)
                _CACHE[f"{modname}.{n}"] = obj
                if inspect.isclass(obj):
                    for attr, value in vars(obj).items():
                        if not attr.startswith("_"):
                            _CACHE[f"{modname}.{n}.{attr}"] = value
    return _CACHE


def register_reexports(app, env) -> list[str]:
    """``env-updated``: every re-exported name (``dualpose.quat_mul``, ``dualpose.registration.register_pose``) as an
    alias of the entry where the object is documented, so that references and the gallery's code links find it."""
    py = env.domains["py"]
    for name, obj in _api_objects().items():
        target = _canonical_name(obj, name) or _documented_constant(obj, name)
        if target and target != name and target in py.objects and name not in py.objects:
            py.objects[name] = py.objects[target]._replace(aliased=True)
    return []


#: names as the source writes them in annotations (``ArrayLike``, ``np.float64``) -> their documented names; autodoc
#: leaves an overload's annotations as written
_SOURCE_NAMES = {"ArrayLike": "numpy.typing.ArrayLike", "NDArray": "numpy.typing.NDArray"}


def resolve_source_name(app, env, node, contnode):
    """``missing-reference``: ``np.X`` and the :mod:`numpy.typing` aliases, as written in an annotation, through the
    numpy inventory."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"]
    name = _SOURCE_NAMES.get(target) or ("numpy." + target[3:] if target.startswith("np.") else None)
    if name is None:
        return None
    from sphinx.ext.intersphinx import missing_reference

    node["reftarget"] = name
    found = missing_reference(app, env, node, contnode)
    if found is None:
        node["reftarget"] = target
    return found


def resolve_dualpose_reference(app, env, node, contnode):
    """``missing-reference``: resolve a Python reference to a dualpose object named by a re-export or bare name."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"]
    name = canonical_target(target, node.get("py:module"))
    if name is None or name == target:
        return None
    found = env.get_domain("py").resolve_any_xref(env, node["refdoc"], app.builder, name, node, contnode)
    return found[0][1] if found else None


def public_bases(app, name, obj, options, bases: list) -> None:
    """``autodoc-process-bases``: show a private base (``_Batch``) as its own public bases."""
    i = 0
    while i < len(bases):
        base = bases[i]
        if isinstance(base, type) and any(p.startswith("_") for p in f"{base.__module__}.{base.__name__}".split(".")
                                          if p not in ("__main__",)):
            bases[i:i + 1] = [b for b in base.__bases__ if b is not object]
            continue
        i += 1


def factory_defaults(app, what, name, obj, options, signature, return_annotation):
    """``autodoc-process-signature``: a dataclass field's ``default_factory`` shown as ``dict()``, not ``<factory>``."""
    import dataclasses

    if what != "class" or not signature or "<factory>" not in signature or not dataclasses.is_dataclass(obj):
        return None
    for field in dataclasses.fields(obj):
        if field.default_factory is not dataclasses.MISSING:
            factory = getattr(field.default_factory, "__name__", "<lambda>")
            signature = signature.replace("<factory>", "..." if factory == "<lambda>" else f"{factory}()", 1)
    return signature, return_annotation


def _name_of_alias(self) -> str:
    return self.name


def _subscript_alias(self, item):
    """``NDArray[np.float64]`` with ``NDArray`` an ``autodoc_type_aliases`` alias: the alias of the whole expression
    (``numpy.typing.NDArray[numpy.float64]``), which the signature shows with a link for each name.  Without it
    the subscript raises inside ``typing.get_type_hints`` and autodoc leaves every annotation of the function
    unevaluated."""
    from sphinx.util.inspect import TypeAliasForwardRef
    from sphinx.util.typing import stringify_annotation

    items = item if isinstance(item, tuple) else (item,)
    names = ", ".join(i.name if isinstance(i, TypeAliasForwardRef) else stringify_annotation(i, "fully-qualified")
                      for i in items)
    return TypeAliasForwardRef(f"{self.name}[{names}]")


def setup(app):
    # Sphinx writes an ``autodoc_type_aliases`` alias inside a union (``ArrayLike | None``) with its repr,
    # ``TypeAliasForwardRef('numpy.typing.ArrayLike')``; the alias's own name is what the signature should show
    from sphinx.util.inspect import TypeAliasForwardRef

    TypeAliasForwardRef.__repr__ = _name_of_alias
    TypeAliasForwardRef.__getitem__ = _subscript_alias
    app.connect("builder-inited", generate_api)
    app.connect("missing-reference", resolve_dualpose_reference)
    app.connect("missing-reference", resolve_source_name)
    app.connect("env-updated", register_reexports)
    app.connect("autodoc-process-bases", public_bases)
    app.connect("autodoc-process-signature", factory_defaults)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

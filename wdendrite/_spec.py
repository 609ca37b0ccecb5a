"""What the command knows about presets: parameters found by introspection, typed values, TOML configs.

A preset is any public function of :mod:`wdendrite.presets` (and the command's own
models in :mod:`wdendrite.cli`). Its keyword parameters, their defaults,
annotations and docstring lines give the options; a frozen-dataclass parameter
(``params: LightningParams = LightningParams()``) is flattened into its fields,
documented by the field docstrings. Parameters whose type the command cannot
spell (arrays, tapers) keep their defaults and are listed as Python-only.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re
import sys
import textwrap
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Param", "Preset", "UsageError", "all_presets", "nearest", "parse_config", "read_toml", "resolve"]

ALIASES = {"elm_tree": "tree", "staghorn_coral": "coral", "lichen_on_rock": "lichen"}
"""Command names of presets whose function names are long."""

RESERVED = ("device", "progress", "out", "force", "quiet", "config", "heightmap", "range", "help", "workers")
"""Parameter names the command's own options use; presets' parameters of these names keep their defaults."""

SIZE_NAMES = ("shape", "size", "cell", "height")
"""Parameters that ``--size`` sets (the first one a preset has)."""

UNITS = {
    "shape": "nodes", "size": "nodes", "cell": "nodes", "height": "nodes", "endpoints": "count",
    "count": "count", "forks": "count", "minor_forks": "count", "neighbours": "count", "iterations": "count",
    "levels": "count", "generators": "count", "refine_n": "subdivisions", "smooth": "passes",
    "primitive_steps": "levels", "glow_radius": "pixels", "main_width": "pixels", "fork_width": "pixels",
    "minor_width": "pixels", "r": "weight units", "d": "weight units",
    "epsilon": "weight units", "extent": "domain units", "resolution": "cells per domain unit",
    "frequency": "features per control unit", "paths_per_1000": "paths per 1000 nodes", "start": "pixels",
    "end": "pixels", "cheap": "fraction", "eps": "fraction of a cell", "fine_eps": "fraction of a cell",
    "primitive_eps": "fraction of a cell", "delta": "fraction of a segment", "outlets": "",
    "minor_gain": "fraction", "glow_gain": "gain", "descent": "fraction", "gap": "pixels",
    "glow_alpha": "dimensionless", "noise": "fraction", "strength": "factor",
    "alpha": "dimensionless", "alphas": "dimensionless", "beta": "dimensionless", "betas": "dimensionless",
    "ns": "exponents", "seed": "", "text": "", "toward": "", "geometry": "", "rule": "", "output": "",
    "control": "", "connectivity": "", "smoothing": "", "subdivision": "", "drained": "", "colormap": "",
}
"""Units shown in ``--help`` by parameter name."""


DOCS = {
    "shape": "lattice shape, (H, W) or (D, H, W)",
    "seed": "random seed: the same seed gives the same output",
    "endpoints": "number of endpoints traced back to the generator(s)",
    "count": "endpoints of the first fractal growth iteration",
    "iterations": "fractal growth iterations",
    "cell": "side of each panel's lattice",
    "r": "spread of the uniform weights W = length * (1 + r * R), R uniform in (0, 1)",
    "neighbours": "generators placed around the central one",
    "smooth": "smoothing passes of the mesh",
    "refine_n": "refinement factor n (odd, >= 3), or none for no refinement",
    "ns": "exponents n of the weights W = 1 + v^n, one panel each",
    "toward": "tropism directions (left, right, top, bottom, axis, away_from_axis), one panel each",
    "strength": "tropism strength: weights scale by 1 + strength * g, g from 0 on the cheap side to 1",
    "geometry": "mesh of the branches: tubes, spheres or isosurface",
}
"""Help lines for parameters whose preset docstring has no ``Args:`` entry (a docstring entry wins)."""


class UsageError(ValueError):
    """Bad usage or input: the command prints the message and exits with code 2."""


def edits(a: str, b: str) -> int:
    """The edits (insertions, deletions, substitutions, swaps of neighbours) that turn ``a`` into ``b``
    (the optimal string alignment distance)."""
    prev2, prev = None, list(range(len(b) + 1))
    for i in range(1, len(a) + 1):
        row = [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            row[j] = min(prev[j] + 1, row[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1]))
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                row[j] = min(row[j], prev2[j - 2] + 1)
        prev2, prev = prev, row
    return prev[-1]


def nearest(word: str, names) -> str:
    """``"; did you mean 'x'?"`` for the name of ``names`` fewest edits away (:func:`edits`, case and
    leading dashes aside), or an empty string when none is near: no edit for words of up to 2
    letters, 1 up to 4, 2 up to 8, 3 beyond (a typo, not another word)."""
    bare = str(word).lstrip("-").lower()
    allowed = 0 if len(bare) <= 2 else 1 if len(bare) <= 4 else 2 if len(bare) <= 8 else 3
    scored = sorted((edits(bare, str(n).lstrip("-").lower()), k, str(n)) for k, n in enumerate(names))
    return f"; did you mean {scored[0][2]!r}?" if scored and scored[0][0] <= allowed else ""


# --------------------------------------------------------------------------- parameters


def progress_bar(desc: str, *, quiet: bool, total: int | None = None, leave: bool = True, delay: float = 0.0,
                 **extra):
    """A tqdm bar on stderr, off when ``quiet`` or when the process has no stderr (closed at start:
    tqdm would fail inside its lock and hang the run); ``extra``: further tqdm arguments."""
    off = bool(quiet) or sys.stderr is None
    if off:  # (tqdm.auto, imported in a notebook without ipywidgets, warns even for a bar never shown)
        from tqdm.std import tqdm
    else:
        from tqdm.auto import tqdm

    kw = dict(total=total, desc=desc, disable=off, leave=leave, file=sys.stderr, **extra)
    bar = _drawn_once(tqdm)
    if delay:
        try:
            return bar(**kw, delay=delay)
        except TypeError:  # tqdm < 4.62 has no delay
            pass
    return bar(**kw)


def _drawn_once(tqdm):
    """``tqdm`` whose closing leaves its last line as it was drawn. tqdm draws a kept bar once more when
    it closes (with the overall rate): on a terminal over the same line, but where stderr goes to a
    file or a pipe, as a second copy of the finished bar."""
    from tqdm.std import tqdm as text_bar

    if tqdm.display is not text_bar.display:  # (a notebook's widget bar: closing draws no text)
        return tqdm

    class Bar(tqdm):
        def close(self):
            shown = not self.disable and self.leave and getattr(self, "last_print_n", None) == self.n
            if shown:  # the line on screen is the finished bar: only end it (a no-op display shadows the method)
                self.display = lambda *args, **kwargs: True
            super().close()

    return Bar


def _fmt(v) -> str:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return _fmt(tuple(getattr(v, f.name) for f in dataclasses.fields(v)))
    if isinstance(v, (tuple, list)):
        return ",".join(_fmt(x) for x in v)
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


@dataclass
class Param:
    """One option of a preset."""

    name: str
    """Python parameter (or dataclass field) name."""
    default: object
    """Default value."""
    kind: str
    """int, float, bool, str, choice, ints, floats, strs, int?, float?, float+ (one number or a list)
    or nested (a small frozen dataclass such as a Taper, given as its field values in order)."""
    choices: tuple = ()
    """Allowed strings of a ``choice``."""
    doc: str = ""
    """Help line from the docstring."""
    group: str | None = None
    """The dataclass parameter this field belongs to (None: a plain parameter)."""
    own_unit: str | None = None
    """Unit the preset's function names for this parameter (its ``units`` attribute), else None."""

    @property
    def unit(self) -> str:
        """Unit shown in the help (empty when dimensionless or not a quantity)."""
        if self.own_unit is not None:
            return self.own_unit
        if self.name in UNITS:
            return UNITS[self.name]
        return "count" if self.kind in ("int", "ints", "int?") else ""

    def help_text(self) -> str:
        """``doc (default: x) [unit]`` with argparse's % escaped."""
        doc = _terminal_text((self.doc or self.name.replace("_", " ")).rstrip("."))
        if self.kind == "choice":
            doc += f"; one of {', '.join(self.choices)}"
        unit = f" [{self.unit}]" if self.unit else ""
        if self.default is None and "(default:" in doc:  # the docstring says what None stands for
            return f"{doc}{unit}".replace("%", "%%")
        return f"{doc} (default: {_fmt(self.default) if self.default is not None else 'none'}){unit}".replace("%", "%%")

    def metavar(self) -> str:
        """Placeholder shown in ``--help``."""
        if self.kind == "nested":
            names = [f.name.upper() for f in dataclasses.fields(self.default)]
            return names[0] + "".join(f"[,{n}" for n in names[1:]) + "]" * (len(names) - 1)
        return {"int": "INT", "float": "X", "str": "TEXT", "choice": "{" + ",".join(self.choices) + "}",
                "ints": "N,N,...", "floats": "X,X,...", "strs": "A,B,...", "int?": "INT|none",
                "float?": "X|none", "float+": "X[,X,...]"}.get(self.kind, "VALUE")

    def convert(self, value, *, source: str | None = None, typed: bool = False):
        """``value`` (a string from the command line, or with ``typed`` a TOML value, whose numbers and
        booleans must be TOML's own, not text) as this parameter's type."""
        where = source or f"'{self.name}'"
        try:
            if self.kind == "nested":
                given = self._fields(value, typed)
            else:
                got = self._convert(value, typed)
        except (TypeError, ValueError):
            pass
        else:
            if self.kind != "nested":
                return self._seed(got, where) if self.name == "seed" and self.kind == "int" else got
            try:
                return dataclasses.replace(self.default, **given)
            except (TypeError, ValueError) as exc:  # the dataclass names the field and its bounds
                raise UsageError(f"{where}: {exc}") from None
        extra = nearest(value, self.choices) if self.kind == "choice" else ""
        if self.kind in ("choice", "str") and isinstance(value, str) and re.search(r"\.[A-Za-z]\w{1,3}$", value):
            extra += "; output files are named with -o/--out"  # e.g. --output d.png
        want = {"int": "an integer", "float": "a number", "bool": "true or false", "str": "text",
                "choice": f"one of {', '.join(self.choices)}", "ints": "integers separated by commas",
                "floats": "numbers separated by commas", "strs": "names separated by commas",
                "int?": "an integer or none", "float?": "a number or none",
                "float+": "a number or numbers separated by commas",
                "nested": f"{self.metavar()} (the fields of {type(self.default).__name__} in order)"}[self.kind]
        if typed and isinstance(value, str) and self.kind not in ("str", "choice", "strs"):
            extra += " (text: in TOML, write numbers and true/false without quotes)"
        raise UsageError(f"{where} expects {want}, but got {value!r}{extra}")

    @staticmethod
    def _seed(value: int, where: str) -> int:
        """A preset's seed in the one range every seed has (the command, config files, job files and
        the library's weights and Dendry), or :class:`UsageError` naming ``where``."""
        from ._checks import seed32

        try:
            return seed32(value)
        except ValueError:
            raise UsageError(f"{where} expects an integer in [0, 2**32), but got {value!r}") from None

    def _convert(self, v, typed: bool = False):
        k = self.kind
        if k in ("int?", "float?") and (v is None or (isinstance(v, str) and v.lower() == "none")):
            return None
        if typed and isinstance(v, str) and k in ("int", "int?", "float", "float?", "bool"):
            raise TypeError  # (TOML has numbers and booleans of its own: text is a mistake there)
        if k in ("int", "int?"):
            if isinstance(v, bool) or not isinstance(v, (int, str)):
                raise TypeError
            return int(v)
        if k in ("float", "float?"):
            if isinstance(v, bool) or not isinstance(v, (int, float, str)):
                raise TypeError
            return float(v)
        if k == "bool":
            if isinstance(v, bool):
                return v
            if isinstance(v, str) and v.lower() in ("true", "false", "yes", "no", "1", "0"):
                return v.lower() in ("true", "yes", "1")
            raise ValueError
        if k in ("str", "choice"):
            if not isinstance(v, str) or (k == "choice" and v not in self.choices):
                raise ValueError
            return v
        items = _items(v, allow_x=k == "ints")
        if k == "float+":
            out = tuple(Param(self.name, None, "float")._convert(x, typed) for x in items)
            return out[0] if len(out) == 1 and not isinstance(v, (list, tuple)) else out
        inner = {"ints": "int", "floats": "float", "strs": "str"}[k]
        return tuple(Param(self.name, None, inner)._convert(x, typed) for x in items)


    def _fields(self, v, typed: bool = False) -> dict:
        """``{field: value}`` of a nested dataclass from its field values in order (the leading ones)."""
        fields = dataclasses.fields(self.default)
        items = _items(v, allow_x=False)
        if not 1 <= len(items) <= len(fields):
            raise ValueError
        return {f.name: Param(f.name, None, _kind_of_value(getattr(self.default, f.name)))._convert(x, typed)
                for f, x in zip(fields, items)}


def _items(v, *, allow_x: bool) -> list:
    if isinstance(v, (list, tuple)):
        if not v:
            raise ValueError  # (an empty TOML list: the caller names the key and what it expects)
        return list(v)
    if isinstance(v, str):
        parts = re.split(r"[,x]" if allow_x else ",", v.strip())
        if any(not p.strip() for p in parts):
            raise ValueError
        return [p.strip() for p in parts]
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return [v]
    raise TypeError


def _kind(annotation, default) -> tuple[str | None, tuple]:
    """(kind, choices) from an annotation (or, without one, from the default); kind None: unsupported."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Literal:
        return ("choice", tuple(str(a) for a in args)) if all(isinstance(a, str) for a in args) else (None, ())
    if origin in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        if len(rest) == 1 and len(args) == 2:
            k, _ = _kind(rest[0], None)
            return (k + "?", ()) if k in ("int", "float") else (None, ())
        if set(rest) == {float} | {a for a in rest if typing.get_origin(a) is tuple}:
            return "float+", ()
        return None, ()
    if origin is tuple:
        inner = [a for a in args if a is not Ellipsis]
        name = {int: "ints", float: "floats", str: "strs"}.get(inner[0] if inner and len(set(inner)) == 1 else None)
        return name, ()
    if annotation in (bool, int, float, str):
        return annotation.__name__, ()
    if annotation is inspect.Parameter.empty or annotation is None:
        return _kind_of_value(default), ()
    if _nested(default) and isinstance(default, annotation if isinstance(annotation, type) else ()):
        return "nested", ()
    return None, ()


def _nested(v) -> bool:
    """A small frozen dataclass of numbers and strings (a Taper): settable as its field values in order."""
    if not dataclasses.is_dataclass(v) or isinstance(v, type) or not v.__dataclass_params__.frozen:
        return False
    return all(_kind_of_value(getattr(v, f.name)) in ("int", "float", "str", "bool") for f in dataclasses.fields(v))


def _kind_of_value(v) -> str | None:
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, int):
        return "int"
    if isinstance(v, float):
        return "float"
    if isinstance(v, str):
        return "str"
    if isinstance(v, tuple) and v:
        if all(isinstance(x, int) and not isinstance(x, bool) for x in v):
            return "ints"
        if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
            return "floats"
        if all(isinstance(x, str) for x in v):
            return "strs"
    return None


def _arg_docs(func) -> dict[str, str]:
    """``{name: first sentence}`` from the Args: section of a docstring."""
    doc = inspect.getdoc(func) or ""
    m = re.search(r"^Args:\n(.*?)(?:^\S|\Z)", doc, re.S | re.M)
    out = {}
    if m:
        for item in re.split(r"\n(?=    \S)", "\n" + m.group(1)):
            head, _, text = item.strip().partition(":")
            for name in head.split(","):
                out[name.strip()] = " ".join(text.split())
    return out


def _field_docs(cls, whole: bool = False) -> dict[str, str]:
    """``{field: docstring}`` of a dataclass whose fields are followed by string literals: the
    first paragraph on one line, or with ``whole`` all of it."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError, SyntaxError):
        return {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    return _docs_of_fields(body, whole)


def _docs_of_fields(body: list, whole: bool) -> dict[str, str]:
    """``{field: docstring}`` from the statements of a class body (see :func:`_field_docs`)."""
    out = {}
    for a, b in zip(body, body[1:]):
        if (isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name) and isinstance(b, ast.Expr)
                and isinstance(b.value, ast.Constant) and isinstance(b.value.value, str)):
            text = b.value.value if whole else b.value.value.split("\n\n")[0]
            out[a.target.id] = " ".join(text.split())
    return out


def counted(n: int, noun: str) -> str:
    """``"1 endpoint"``, ``"2 endpoints"``: ``n`` and ``noun``, plural (with an s) unless ``n`` is 1."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def document_fields(module) -> None:
    """Add a ``Fields`` section, from the string literal under each field, to the docstring of
    each public dataclass defined in ``module``, after its first paragraph: ``help()`` and
    IPython's ``?`` show class docstrings, not those literals. Only the classes' own lines are
    parsed (``inspect.getsource`` of a class parses its whole module each time: 0.15 s an import,
    against about 0.01 s). ``module``: a module or the name of an imported one (a module calls
    ``document_fields(__name__)`` as its last line, so whoever imports it first sees the sections)."""
    if isinstance(module, str):
        module = sys.modules[module]
    try:
        source = inspect.getsource(module).splitlines()
    except (OSError, TypeError):
        return
    starts = [i for i, line in enumerate(source) if line.startswith("class ")]
    for i in starts:
        name = re.match(r"class (\w+)", source[i]).group(1)
        cls = getattr(module, name, None)
        if (cls is None or name.startswith("_") or not dataclasses.is_dataclass(cls)
                or cls.__module__ != module.__name__ or not cls.__doc__ or "\nFields:\n" in cls.__doc__):
            continue
        end = next((j for j in range(i + 1, len(source)) if source[j][:1] not in ("", " ", "\t", ")")), len(source))
        try:
            node = ast.parse("\n".join(source[i:end])).body[0]
        except SyntaxError:
            continue
        docs = _docs_of_fields(node.body, whole=True)
        lines = ["Fields:"]
        for f in dataclasses.fields(cls):
            if f.name in docs:
                default = "" if f.default is dataclasses.MISSING else f" = {f.default!r}"
                text = textwrap.fill(docs[f.name], 88, initial_indent=" " * 8, subsequent_indent=" " * 8)
                lines.append(f"    {f.name}{default}\n{text}")
        if len(lines) > 1:
            head, sep, rest = inspect.cleandoc(cls.__doc__).partition("\n\n")
            cls.__doc__ = head + "\n\n" + "\n".join(lines) + ("\n\n" + rest if sep else "\n")


# --------------------------------------------------------------------------- presets


@dataclass
class Preset:
    """A subcommand: a function and its options."""

    name: str
    func: object
    summary: str
    doc: str
    params: dict = field(default_factory=dict)
    """``{name: Param}``; dataclass fields are flattened in."""
    groups: dict = field(default_factory=dict)
    """``{dataclass parameter: (default instance, [field names])}``."""
    fixed: list = field(default_factory=list)
    """Parameters kept at their defaults (types the command cannot spell)."""
    size_param: str | None = None
    meshes: bool = False
    """True for 3D presets (they return a mesh)."""
    dendrite: bool = True
    """False for presets that make no dendrite (their function's ``makes_dendrite`` attribute)."""

    @property
    def default_size(self):
        d = self.params[self.size_param].default if self.size_param else None
        return max(d) if isinstance(d, tuple) else d

    def sized(self, n) -> object:
        """The value of the size parameter for ``--size n`` (the largest side; other sides keep their ratio)."""
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise UsageError(f"--size expects a positive integer, but got {n!r}")
        d = self.params[self.size_param].default
        if isinstance(d, tuple):
            big = max(d)
            return tuple(max(1, round(x * n / big)) for x in d)
        return n


def _terminal_text(text: str) -> str:
    """Docstring text as a terminal shows it: reST literals and roles (``x``, :func:`x`) as plain words."""
    return re.sub(r":\w+:`~?([^`]*)`", r"\1", text).replace("``", "")


def _summary(func) -> tuple[str, str]:
    doc = _terminal_text(inspect.getdoc(func) or func.__name__)
    first = doc.split("\n\n")[0]
    body = re.split(r"^Args:$", doc, flags=re.M)[0].rstrip()  # the options list the arguments
    return " ".join(first.split()).replace("%", "%%"), body


def make_preset(name: str, func) -> Preset:
    """Introspect ``func`` into a :class:`Preset` named ``name``."""
    try:
        hints = typing.get_type_hints(func)
    except Exception:  # an annotation that cannot be evaluated: fall back to the defaults' types
        hints = {}
    summary, doc = _summary(func)
    p = Preset(name, func, summary, doc)
    docs = _arg_docs(func)
    sig = inspect.signature(func)
    for prm in sig.parameters.values():
        if prm.default is inspect.Parameter.empty or prm.name in RESERVED:
            continue
        ann = hints.get(prm.name, inspect.Parameter.empty)
        if dataclasses.is_dataclass(prm.default) and not isinstance(prm.default, type):
            _flatten(p, prm.name, prm.default, sig)
            continue
        kind, choices = _kind(ann, prm.default)
        if kind is None:
            p.fixed.append(prm.name)
            continue
        doc = docs.get(prm.name) or DOCS.get(prm.name, "")
        if prm.name == "shape" and not docs.get(prm.name) and isinstance(prm.default, tuple):
            doc = "lattice shape, " + ("(H, W)" if len(prm.default) == 2 else "(D, H, W)")  # the preset's own
        p.params[prm.name] = Param(prm.name, prm.default, kind, choices, doc)
    for pname, unit in getattr(func, "units", {}).items():
        if pname in p.params:
            p.params[pname].own_unit = unit
    p.size_param = next((n for n in SIZE_NAMES if n in p.params), None)
    shape = p.params.get("shape")
    p.meshes = bool(shape and isinstance(shape.default, tuple) and len(shape.default) == 3)
    p.dendrite = bool(getattr(func, "makes_dendrite", True))
    return p


def _flatten(p: Preset, argname: str, instance, sig) -> None:
    cls = type(instance)
    try:
        hints = typing.get_type_hints(cls)
    except Exception:
        hints = {}
    docs = _field_docs(cls)
    names = []
    for f in dataclasses.fields(cls):
        if f.name in sig.parameters:  # the function's own parameter of that name wins (e.g. seed)
            continue
        value = getattr(instance, f.name)
        kind, choices = _kind(hints.get(f.name, inspect.Parameter.empty), value)
        if kind is None or f.name in p.params or f.name in RESERVED:  # unspellable, or the name is taken
            p.fixed.append(f"{argname}.{f.name}")
            continue
        p.params[f.name] = Param(f.name, value, kind, choices, docs.get(f.name, ""), group=cls.__name__)
        names.append(f.name)
    p.groups[argname] = (instance, names)


_CACHE: dict = {}


def canonical_name(name):
    """The command's name of a preset also given by its function's name (``elm_tree`` or
    ``elm-tree``: ``tree``; ``simple_dendrite``: ``simple-dendrite``); anything else unchanged."""
    if not isinstance(name, str):
        return name
    return ALIASES.get(name.replace("-", "_"), name.replace("_", "-"))


def preset_summaries() -> dict[str, str] | None:
    """Every preset's command name and one-line summary, as :func:`all_presets` gives them, read from
    the source of :mod:`wdendrite.presets` and the command's own models without importing them (nor
    Warp), for ``wdendrite --help``; None when a source is unavailable or holds a preset this reading
    cannot see (then only :func:`all_presets` knows)."""
    import ast

    def functions(filename):
        tree = ast.parse((Path(__file__).with_name(filename)).read_text(encoding="utf-8"))
        return tree, {n.name: n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}

    def summary(node) -> str:
        doc = _terminal_text(ast.get_docstring(node) or node.name)
        return " ".join(doc.split("\n\n")[0].split()).replace("%", "%%")

    try:
        tree, defs = functions("presets.py")
        names = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                     and any(getattr(t, "id", None) == "__all__" for t in n.targets))
        found = {}
        imported = {a.asname or a.name: n.module for n in tree.body if isinstance(n, ast.ImportFrom)
                    and n.level == 1 and n.module for a in n.names}
        for fname in names:
            node = defs.get(fname)
            if node is None and fname in imported:  # (a name a sibling module defines)
                node = functions(f"{imported[fname]}.py")[1].get(fname)
            if node is None:  # (a name bound otherwise: an alias, a wrapped function)
                return None
            if isinstance(node, ast.FunctionDef):
                found[ALIASES.get(fname, fname.replace("_", "-"))] = summary(node)
        tree, defs = functions("_models.py")
        models = next(n.value for n in tree.body if isinstance(n, ast.Assign)
                      and any(getattr(t, "id", None) == "MODELS" for t in n.targets))
        for key, value in zip(models.keys, models.values):
            name, node = ast.literal_eval(key), defs.get(getattr(value, "id", None))
            if not isinstance(node, ast.FunctionDef):
                return None
            found.setdefault(name, summary(node))
    except (OSError, SyntaxError, ValueError, StopIteration, AttributeError):
        return None
    return dict(sorted(found.items()))


def all_presets() -> dict[str, Preset]:
    """Every preset by command name: ``wdendrite.presets`` first, then the command's own models."""
    if "all" in _CACHE:
        return _CACHE["all"]
    from ._models import MODELS

    found = {}
    try:
        from . import presets as mod
    except Exception as exc:  # a broken presets module must not take the whole command down
        print(f"wdendrite: warning: the presets are unavailable ({type(exc).__name__}: {exc})", file=sys.stderr)
        mod = None
    for fname in getattr(mod, "__all__", []):
        func = getattr(mod, fname, None)
        if inspect.isfunction(func):
            name = ALIASES.get(fname, fname.replace("_", "-"))
            try:
                found[name] = make_preset(name, func)
            except Exception as exc:  # one odd signature must not hide the other presets
                print(f"wdendrite: warning: preset {name!r} skipped ({type(exc).__name__}: {exc})", file=sys.stderr)
    for name, func in MODELS.items():
        if name not in found:
            found[name] = make_preset(name, func)
    _CACHE["all"] = dict(sorted(found.items()))
    return _CACHE["all"]


def resolve(preset: Preset, values: dict) -> tuple[dict, dict]:
    """Keyword arguments for ``preset.func`` from typed ``values``, and every parameter's value (for manifests).

    Raises:
        UsageError: a name the preset does not have.
        ValueError: a dataclass rejects a value (its message names the field).
    """
    for k in values:
        if k not in preset.params:
            raise UsageError(f"preset {preset.name!r} has no parameter {k!r}{nearest(k, preset.params)}")
    kwargs, full = {}, {}
    grouped = {n for _, names in preset.groups.values() for n in names}
    for k, prm in preset.params.items():
        full[k] = _plain(values.get(k, prm.default))
        if k in values and k not in grouped:
            kwargs[k] = values[k]
    for argname, (instance, names) in preset.groups.items():
        given = {n: values[n] for n in names if n in values}
        if given:
            kwargs[argname] = dataclasses.replace(instance, **given)
    return kwargs, full


def _plain(v):
    """``v`` as JSON-ready data (tuples as lists, small dataclasses as dicts) for manifests."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: _plain(getattr(v, f.name)) for f in dataclasses.fields(v)}
    return list(_plain(x) for x in v) if isinstance(v, tuple) else v


def read_toml(path, what: str) -> dict:
    """A TOML file as a dict; a missing file or a syntax error is a :class:`UsageError` quoting the line."""
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        try:
            import tomli as tomllib
        except ImportError:
            raise UsageError(f"reading {what} needs tomli on Python < 3.11: pip install tomli") from None
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")  # (TOML files are UTF-8, whatever the locale)
    except OSError as exc:
        raise UsageError(f"{what} {str(path)!r}: cannot read it ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise UsageError(f"{what} {str(path)!r} is not UTF-8 text, as TOML files must be ({exc.reason} at "
                         f"byte {exc.start})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UsageError(f"{what} {str(path)!r} does not parse: {exc}{_line_of(exc, text)}") from None


def parse_config(path, preset: Preset) -> dict:
    """Typed values from a TOML file whose keys are ``preset``'s parameters (``size`` allowed too)."""
    path = Path(path)
    raw = read_toml(path, "--config")
    if "size" in raw and preset.size_param in raw and preset.size_param != "size":
        raise UsageError(f"config file {str(path)!r} gives 'size' and {preset.size_param!r}; give one of them")
    out = {}
    for k, v in raw.items():
        if k == "size" and preset.size_param:
            try:
                out[preset.size_param] = preset.sized(v)
            except UsageError:
                raise UsageError(f"config key 'size' in {str(path)!r} expects a positive integer, "
                                 f"but got {v!r}") from None
        elif k in preset.params:
            out[k] = preset.params[k].convert(v, source=f"config key '{k}' in {str(path)!r}", typed=True)
        else:
            raise UsageError(f"config key {k!r} in {str(path)!r} is not a parameter of preset "
                             f"{preset.name!r}{nearest(k, list(preset.params) + ['size'])}")
    return out


def _line_of(exc, text: str) -> str:
    """The line a TOML error points at, quoted (the last line for errors at the end of the document)."""
    lines = text.splitlines()
    m = re.search(r"line (\d+)", str(exc))
    if m:
        i = int(m.group(1)) - 1
    elif "end of document" in str(exc):
        i = max((j for j, ln in enumerate(lines) if ln.strip()), default=-1)
    else:
        return ""
    return f"\n  line {i + 1}: {lines[i]}" if 0 <= i < len(lines) else ""

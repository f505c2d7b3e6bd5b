"""Test helper: ctypes declarations read from C headers, so that no signature or struct is typed twice.

:func:`read` parses the headers of a folder (and generated ones) with pycparser, after a small
preprocessing of their own: comments and preprocessor lines removed, the headers in the order of
their ``#include "..."`` lines, object-like ``#define`` constants kept for array sizes.  That is
enough for the native core's headers (declarations, structs, enums, no conditional declarations);
anything it cannot map is an error naming the header's declaration.  No compiler is needed (the
tests that skip without gcc can still import the binding).

The result, :class:`Binding`: ``structs`` (every ``typedef struct {...} name``: a ctypes
``Structure`` class of that name, the members in order, nested structs by value) and ``functions``
(every prototype: ``(restype, argtypes)``).  Mapped types: ``double``, ``int``, ``long``,
``size_t``, ``int32_t``, ``uint32_t``, enums (``int``), ``char *`` (``c_char_p``), ``T *`` and
``T[n]`` of a number type (``POINTER(T)``), ``void *`` and a pointer to a struct
(:func:`struct_pointer`: that struct, a ``byref`` of it, or a raw ctypes buffer, since tests keep
the large structs in zeroed buffers of their size).
"""

from __future__ import annotations

import ctypes
import re
from pathlib import Path

from pycparser import c_ast, c_generator, c_parser

_BASE = {("double",): ctypes.c_double, ("int",): ctypes.c_int, ("long",): ctypes.c_long,
         ("unsigned", "int"): ctypes.c_uint, ("unsigned",): ctypes.c_uint, ("char",): ctypes.c_char,
         ("size_t",): ctypes.c_size_t, ("int32_t",): ctypes.c_int32, ("uint32_t",): ctypes.c_uint32,
         ("unsigned", "long"): ctypes.c_ulong, ("long", "long"): ctypes.c_longlong,
         ("unsigned", "char"): ctypes.c_ubyte, ("float",): ctypes.c_float}
# the typedefs of the standard headers the core's headers include (<stddef.h>, <stdint.h>)
_PRELUDE = "typedef unsigned long size_t; typedef int int32_t; typedef unsigned int uint32_t;\n"
_CARG = type(ctypes.byref(ctypes.c_int()))


def struct_pointer(cls):
    """An argtypes entry for ``const cls *`` / ``cls *``: an instance of ``cls`` (passed by reference),
    ``byref`` of one, a ctypes array (a raw buffer of the struct's size), ``None`` or an address;
    an instance of another Structure is refused (TypeError naming both)."""

    def from_param(_, obj):
        target = obj._obj if isinstance(obj, _CARG) else obj
        if isinstance(target, ctypes.Structure) and not isinstance(target, cls):
            raise TypeError(f"expected a {cls.__name__}, got a {type(target).__name__}")
        if isinstance(obj, ctypes.Structure):
            return ctypes.byref(obj)
        if isinstance(obj, ctypes.Array):
            return obj
        return ctypes.c_void_p.from_param(obj)

    return type(f"{cls.__name__}_pointer", (), {"from_param": classmethod(from_param)})


class Binding:
    """``structs``: name -> ctypes Structure; ``functions``: name -> (restype, argtypes);
    ``constants``: the object-like ``#define`` numbers by name."""

    def __init__(self, structs, functions, constants):
        self.structs, self.functions, self.constants = structs, functions, constants

    def declare(self, lib):
        """Set restype and argtypes of every function of the headers on the ctypes library ``lib``
        (those the library lacks are skipped); returns lib."""
        for name, (res, args) in self.functions.items():
            f = getattr(lib, name, None)
            if f is not None:
                f.restype, f.argtypes = res, args
        return lib


def _strip(text):
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def _ordered(texts):
    """The headers (name -> text) in an order where each comes after the headers it includes."""
    done, out = set(), []

    def visit(name, path=()):
        if name in done or name not in texts:
            return
        if name in path:
            raise ValueError(f"include cycle: {' -> '.join((*path, name))}")
        for inc in re.findall(r'#include\s+"([^"]+)"', texts[name]):
            visit(inc, (*path, name))
        done.add(name)
        out.append(name)

    for name in sorted(texts):
        visit(name)
    return out


def _number(text):
    text = text.strip()
    if re.fullmatch(r"[-+]?\d+", text):
        return int(text)
    if re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", text):
        return float(text)
    return None


def read(folders, headers=None, known=None):
    """The :class:`Binding` of the ``*.h`` files of ``folders`` (a list of folders; or only the files
    named in ``headers``, a dict name -> text that also adds generated headers).  ``known``: struct
    name -> ctypes class already defined (used as they are; their fields must be the header's)."""
    texts = dict(headers or {})
    for folder in folders:
        for p in sorted(Path(folder).glob("*.h")):
            texts.setdefault(p.name, p.read_text())
    constants, body = {}, []
    for name in _ordered(texts):
        lines = []
        for line in _strip(texts[name]).split("\n"):
            m = re.match(r"\s*#\s*define\s+([A-Za-z_]\w*)\s+(.+)$", line)
            if m and _number(m.group(2)) is not None:
                constants[m.group(1)] = _number(m.group(2))
            lines.append("" if line.lstrip().startswith("#") else line)
        body.append("\n".join(lines))
    ast = c_parser.CParser().parse(_PRELUDE + "\n".join(body), filename="<core headers>")
    return _Reader(constants, known or {}).read(ast)


class _Reader:
    def __init__(self, constants, known):
        self.constants, self.known = constants, dict(known)
        self.types, self.structs, self.functions = {}, {}, {}
        self.enum_values = {}

    def read(self, ast):
        for node in ast.ext:
            try:
                if isinstance(node, c_ast.Typedef):
                    self.typedef(node)
                elif isinstance(node, c_ast.Decl) and isinstance(node.type, c_ast.FuncDecl):
                    self.functions[node.name] = self.function(node)
                elif isinstance(node, c_ast.Decl) and isinstance(node.type, c_ast.Enum):
                    self.enum(node.type)
            except ValueError as e:
                raise ValueError(f"the declaration of {node.name or 'an enum'}: {e}") from None
        return Binding(self.structs, self.functions, {**self.constants, **self.enum_values})

    def fail(self, node, what):
        text = c_generator.CGenerator().visit(node)
        raise ValueError(f"{what} {text!r}: no ctypes mapping in tests/c_binding.py")

    def size(self, node):
        if isinstance(node, c_ast.Constant):
            return int(node.value.rstrip("uUlL"), 0)
        if isinstance(node, c_ast.ID) and node.name in {**self.constants, **self.enum_values}:
            return int({**self.constants, **self.enum_values}[node.name])
        if isinstance(node, c_ast.BinaryOp) and node.op in "+-*/":
            a, b = self.size(node.left), self.size(node.right)
            return {"+": a + b, "-": a - b, "*": a * b, "/": a // b if b else 0}[node.op]
        return self.fail(node, "an array size")

    def enum(self, enum):
        value = -1
        for e in enum.values.enumerators if enum.values else ():
            value = self.size(e.value) if e.value is not None else value + 1
            self.enum_values[e.name] = value

    def typedef(self, node):
        t = node.type
        if isinstance(t, c_ast.TypeDecl) and isinstance(t.type, c_ast.Struct):
            self.types[node.name] = self.struct(node.name, t.type)
        elif isinstance(t, c_ast.TypeDecl) and isinstance(t.type, c_ast.Enum):
            self.enum(t.type)
            self.types[node.name] = ctypes.c_int
        else:
            self.types[node.name] = self.ctype(t)

    def struct(self, name, struct):
        fields = [(d.name, self.ctype(d.type)) for d in struct.decls or ()]
        cls = self.known.get(name)
        if cls is None:
            cls = type(name, (ctypes.Structure,), {"_fields_": fields})
        elif [(n, ctypes.sizeof(t)) for n, t in cls._fields_] != [(n, ctypes.sizeof(t)) for n, t in fields]:
            raise ValueError(f"{name}: the header's members are not those of {cls}")
        self.structs[name] = cls
        return cls

    def ctype(self, t):
        """The ctypes type of a declared type (a struct member's, a typedef's)."""
        if isinstance(t, c_ast.TypeDecl):
            inner = t.type
            if isinstance(inner, c_ast.IdentifierType):
                names = tuple(inner.names)
                if names in _BASE:
                    return _BASE[names]
                if len(names) == 1 and names[0] in self.types:
                    return self.types[names[0]]
            if isinstance(inner, c_ast.Enum):
                self.enum(inner)
                return ctypes.c_int
            return self.fail(t, "a type")
        if isinstance(t, c_ast.ArrayDecl):
            return self.ctype(t.type) * self.size(t.dim)
        if isinstance(t, c_ast.PtrDecl):
            return ctypes.c_char_p if self._names(t.type) == ("char",) else ctypes.c_void_p
        return self.fail(t, "a type")

    @staticmethod
    def _names(t):
        if isinstance(t, c_ast.TypeDecl) and isinstance(t.type, c_ast.IdentifierType):
            return tuple(t.type.names)
        return None

    def param(self, t):
        """The argtypes entry of a parameter's type."""
        if isinstance(t, c_ast.ArrayDecl | c_ast.PtrDecl):
            names = self._names(t.type)
            if names == ("char",):
                return ctypes.c_char_p
            if names == ("void",) or names is None:
                return ctypes.c_void_p
            target = self.ctype(t.type)
            if isinstance(target, type) and issubclass(target, ctypes.Structure):
                return struct_pointer(target)
            return ctypes.POINTER(target)
        return self.ctype(t)

    def function(self, node):
        f = node.type
        res = None if self._names(f.type) == ("void",) else (
            ctypes.c_char_p if isinstance(f.type, c_ast.PtrDecl) and self._names(f.type.type) == ("char",)
            else self.ctype(f.type))
        args = []
        for p in f.args.params if f.args else ():
            if isinstance(p, c_ast.Typename) and self._names(p.type) == ("void",):
                continue  # f(void)
            args.append(self.param(p.type))
        return res, args

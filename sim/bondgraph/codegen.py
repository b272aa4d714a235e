"""Code generation: a bond graph's sorted equations become a compiled Python module.

The module holds straight-line scalar code for the right-hand side ``rhs(t, y, p, dy)``
and for the outputs, plus the integrators (:mod:`sim.solver.rosenbrock`'s ROS2, :mod:`sim.solver.rodas`'s
RODAS4) and the steady-state solver specialised to this right-hand side.  Everything is
compiled by numba with ``cache=True``; the module is written to a cache folder under a
name that hashes its source, so a second process loads the machine code instead of
compiling it again.  With ``jit=False`` the same source runs as plain Python (the
baseline of the benchmark and a debugging aid).
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import textwrap
import threading
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

from sim.bondgraph.equations import EquationSystem
from sim.solver import rodas, rosenbrock

__all__ = ["cache_dir", "generate_source", "load_module"]

#: (module, function) copied into every generated module, in dependency order
_SOLVER_SOURCES = (
    (rosenbrock, "lu_factor"), (rosenbrock, "lu_solve"), (rosenbrock, "fd_jacobian"),
    (rosenbrock, "integrate"), (rosenbrock, "steady"),
    (rodas, "grow_rows"), (rodas, "dense_eval"), (rodas, "integrate_rodas"),
)
_SOLVER_FUNCS = tuple(name for _, name in _SOLVER_SOURCES)


def cache_dir() -> Path:
    """Folder of generated modules: ``$HYDRODIAG_CACHE_DIR`` or ``~/.cache/hydrodiag``."""
    env = os.environ.get("HYDRODIAG_CACHE_DIR")
    path = Path(env) if env else Path.home() / ".cache" / "hydrodiag"
    path.mkdir(parents=True, exist_ok=True)
    return path


class _DropRhs(ast.NodeTransformer):
    """Remove the leading ``rhs`` parameter from definitions and calls."""

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.FunctionDef:
        self.generic_visit(node)
        if node.args.args and node.args.args[0].arg == "rhs":
            node.args.args = node.args.args[1:]
        node.returns = None
        for a in node.args.args:
            a.annotation = None
        node.decorator_list = [ast.Name(id="_jit", ctx=ast.Load())]
        return node

    def visit_Call(self, node: ast.Call) -> ast.Call:
        self.generic_visit(node)
        if (isinstance(node.func, ast.Name) and node.func.id in _SOLVER_FUNCS and node.args
                and isinstance(node.args[0], ast.Name) and node.args[0].id == "rhs"):
            node.args = node.args[1:]
        return node


def _solver_source() -> str:
    parts = []
    for mod, name in _SOLVER_SOURCES:
        src = textwrap.dedent(inspect.getsource(getattr(mod, name)))
        tree = _DropRhs().visit(ast.parse(src))
        parts.append(ast.unparse(ast.fix_missing_locations(tree)))
    consts = "\n".join(f"{k} = {getattr(mod, k)!r}" for mod in (rosenbrock, rodas)
                       for k in dir(mod) if k.startswith(("STATUS_", "R4_")))
    return consts + "\n\n" + "\n\n\n".join(parts)


def _law_import(lname: str, func: Any, jit: bool) -> str:
    py = getattr(func, "py_func", func)
    mod, name = py.__module__, py.__name__
    if jit:
        return f"from {mod} import {name} as {lname}"
    return f"from {mod} import {name} as _{lname}\n{lname} = getattr(_{lname}, 'py_func', _{lname})"


def _law_fingerprint(laws: Mapping[str, Any]) -> str:
    """SHA-1 of the source of every module that defines one of ``laws``.

    The generated module only imports its laws, and numba's cache of a function does not
    notice a change in a function it calls: without this in the generated source (whose
    hash names the cached module) a law edited in :mod:`sim.components` kept running its
    old machine code from a warm cache (a mutation review: the valve path's √ΔP made ΔP⁰
    passed every rig test until the cache was emptied).  The whole module is hashed, so a
    helper the law calls in its own module counts too.
    """
    parts = []
    for lname, func in sorted(laws.items()):
        py = getattr(func, "py_func", func)
        module = sys.modules.get(py.__module__)
        try:
            text = inspect.getsource(module) if module is not None else ""
        except (OSError, TypeError):  # a law without a source file (built at run time)
            text = ""
        if not text:  # its byte code and plain constants (no code objects: their repr
            # holds an address, which would name a new module in every process)
            code = py.__code__
            consts = [c for c in code.co_consts
                      if c is None or isinstance(c, bool | int | float | complex | str | bytes)]
            text = f"{code.co_code.hex()} {consts!r}"
        parts.append(f"{lname} {py.__module__}.{py.__qualname__}\n{text}")
    return hashlib.sha1("\n".join(parts).encode()).hexdigest()


def generate_source(system: EquationSystem, *, jit: bool = True) -> str:
    """Python source of the compiled model (see module docstring)."""
    head = [
        f"# generated by hydrodiag from bond graph {system.graph.name!r}; do not edit",
        f"# laws' source sha1 {_law_fingerprint(system.laws)}",
        "import math",
        "import numpy as np",
    ]
    if jit:
        head += ["from numba import njit", "_jit = njit(cache=True, error_model='numpy')"]
    else:
        head += ["def _jit(f):", "    return f"]
    head += [_law_import(lname, f, jit) for lname, f in sorted(system.laws.items())]
    body = [eq_line for eq in system.equations for eq_line in [f"    {eq.target} = {eq.code}"]]
    rhs = ["@_jit", "def rhs(t, y, p, dy):", *body]
    rhs += [f"    dy[{i}] = {code}" for i, (_, code) in enumerate(system.derivatives)]
    out = ["@_jit", "def outputs(t, y, p, out):", *body]
    out += [f"    out[{i}] = {code}" for i, (_, code, _) in enumerate(system.outputs)]
    if not system.outputs:
        out.append("    return")
    nb = len(system.graph.bonds)
    bonds = ["@_jit", "def bond_values(t, y, p, e, f):", *body]
    bonds += [f"    e[{i}] = e_{i}\n    f[{i}] = f_{i}" for i in range(nb)]
    batch = [
        "@_jit",
        "def outputs_batch(ts, ys, p, out):",
        "    for k in range(ts.size):",
        "        outputs(ts[k], ys[k], p, out[k])",
    ]
    blocks = ["\n".join(head), "\n".join(rhs), "\n".join(out), "\n".join(bonds),
              "\n".join(batch), _solver_source()]
    return "\n\n\n".join(blocks) + "\n"


#: Serialises :func:`load_module`: a module becomes visible to other threads only once it
#: has finished executing (a concurrent first caller must never see a half-loaded module).
_LOAD_LOCK = threading.Lock()


def load_module(source: str) -> ModuleType:
    """Write ``source`` to the cache folder (once) and import it, once per process.

    Thread-safe: concurrent first callers wait for the one that loads the module and then
    get the fully executed module.  ``sys.modules`` holds the module while it executes (as
    :mod:`importlib` does, so that code which looks itself up there works) but the lock is
    held until execution has finished, and a module whose execution fails is removed again.
    """
    digest = hashlib.sha1(source.encode()).hexdigest()[:20]
    modname = f"hydrodiag_bg_{digest}"
    with _LOAD_LOCK:
        loaded = sys.modules.get(modname)
        if loaded is not None:
            return loaded
        path = cache_dir() / f"{modname}.py"
        # UTF-8 whatever the locale: the source holds ∂ and ·, and under ISO-8859-1 or an
        # ASCII locale every command failed reading or writing it, and left its .tmp file
        # behind (a CLI pass)
        if not path.exists() or path.read_text(encoding="utf-8") != source:
            fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
            try:
                with os.fdopen(fd, "w", encoding="utf-8") as fh:
                    fh.write(source)
                os.replace(tmp, path)
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
        spec = importlib.util.spec_from_file_location(modname, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[modname] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[modname]
            raise
        return module

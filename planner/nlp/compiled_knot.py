"""Compiled per-knot derivatives (issue #16): one knot's J(u) and H(u, λ) as a shared library.

`planner.nlp.solver_cache` hands CasADi one knot's sparse Jacobian J and Lagrangian Hessian H as
SX functions, evaluated by CasADi's virtual machine. Here the same two functions are
code-generated (`casadi.CodeGenerator`) into C, compiled once per robot with the C compiler and
loaded with `casadi.external`; they evaluate several times faster and load in milliseconds
instead of the seconds it takes to read the serialised SX.

The generated library also carries the *Jacobian sparsity* of J and H (``CodeGenerator.add(f,
True)`` writes ``jac_<name>_sparsity_out``, which `casadi.external` reads): without it CasADi
assumes every output of an external function depends on every input, so the sparsity of the
whole NLP's Hessian it derives through ``H(u, λ)`` is wrong (denser), other derivative
directions are asked for and the build fails. With it the NLP's Jacobian and Hessian have
exactly the SX path's patterns, and the values agree to rounding.

Compiling takes about a minute of CPU (a robot's H is ~160K instructions, 5 MB of C), so no
command waits for it unless asked to: ``PlannerOptions(derivatives="compiled")`` (``gaitsmith
plan --solver compiled``) and ``gaitsmith cache build ROBOT`` compile in the foreground; the
default ``derivatives="knot"`` finds the library in the disk cache and uses it, and when it finds
none it starts the compile in a detached background process for the next command
(`planner.nlp.background_compile`).

Disk cache (beside the direction counts, ``$GAITSMITH_CACHE`` or ``~/.cache/gaitsmith/``):
``knot-<key>.so`` and its manifest ``knot-<key>.json``. The key is the knot's key
(`solver_cache.knot_cache_key`: the robot's model, casadi and gaitsmith versions) plus the
compiler's path and ``--version`` line and the flags. The library is written to a temporary
name and moved into place atomically, the manifest (its SHA-256, sizes, function names) after
it; a library whose bytes do not match its manifest, or a manifest of another key, is rebuilt,
never loaded (a corrupt shared library could crash the process when opened). No C compiler:
a one-line warning and the SX path.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from planner.errors import PlannerError
from robots.errors import OutputWriteError
from robots.files import atomic_write_bytes

#: bump when the library's or the manifest's layout changes
COMPILED_FORMAT = "knot-compiled-1"
#: the optimisation flag used unless asked otherwise (docs/results/planner_speed_compiled.md:
#: quad12's J and H compile in ~2 min at -O1; -O2/-O3 take longer for no faster solve)
DEFAULT_FLAGS = ("-O1",)
#: a compile that has not finished after this long is stopped (and the SX path used)
COMPILE_TIMEOUT_S = 3600.0
#: ``$GAITSMITH_CC`` names the C compiler; else the first of these on the PATH
COMPILER_NAMES = ("gcc", "cc")


class CompileError(PlannerError):
    """Generating or compiling the knot derivatives failed (message says what to do)."""


@dataclass(frozen=True)
class Compiler:
    """A C compiler and the flags the knot derivatives are compiled with (part of the key)."""

    path: str
    version: str  # first line of ``<path> --version``
    flags: tuple[str, ...] = DEFAULT_FLAGS


def find_compiler(flags: tuple[str, ...] = DEFAULT_FLAGS) -> Compiler | None:
    """``$GAITSMITH_CC`` or the first of `COMPILER_NAMES` on the PATH that answers
    ``--version``; None if there is none."""
    wanted = os.environ.get("GAITSMITH_CC")
    for name in (wanted,) if wanted else COMPILER_NAMES:
        path = shutil.which(name)
        if path is None:
            continue
        try:
            out = subprocess.run(
                [path, "--version"], capture_output=True, text=True, timeout=30, check=True
            ).stdout
        except (OSError, subprocess.SubprocessError):
            continue
        lines = out.splitlines()
        return Compiler(path, lines[0].strip() if lines else "", tuple(flags))
    return None


def warn(message: str) -> None:
    """One line on stderr (a planner still plans, just without the compiled derivatives)."""
    print(f"gaitsmith: warning: {message}", file=sys.stderr)


def compiled_key(sx_key: str, compiler: Compiler) -> str:
    """Hex key of the compiled entry: the knot's key (`solver_cache.knot_cache_key`),
    `COMPILED_FORMAT` and the compiler."""
    digest = hashlib.sha256()
    for part in (COMPILED_FORMAT, sx_key, compiler.path, compiler.version, *compiler.flags):
        digest.update(part.encode() + b"\0")
    return digest.hexdigest()[:32]


@dataclass(frozen=True)
class CompiledEntry:
    """Where one compiled entry lives and what its functions are called inside the library."""

    key: str
    library: Path
    manifest: Path
    n_u: int  # knot inputs stacked
    n_y: int  # knot outputs stacked

    @property
    def jacobian_name(self) -> str:
        return f"gaitsmith_J_{self.key}"

    @property
    def hessian_name(self) -> str:
        return f"gaitsmith_H_{self.key}"


def entry_at(directory: Path, key: str, n_u: int = 0, n_y: int = 0) -> CompiledEntry:
    """The entry of compiled key `key` in the cache folder `directory`: ``knot-<key>.so`` and its
    manifest ``knot-<key>.json`` (`n_u`, `n_y` 0 where only the files matter)."""
    return CompiledEntry(
        key, directory / f"knot-{key}.so", directory / f"knot-{key}.json", n_u, n_y
    )


def compiled_entry(sx_key: str, compiler: Compiler, directory: Path, n_u: int,
                   n_y: int) -> CompiledEntry:
    return entry_at(directory, compiled_key(sx_key, compiler), n_u, n_y)


def _manifest(entry: CompiledEntry, library_sha256: str, compiler: Compiler,
              jac_sparsity_nnz: list[int], label: str = "") -> dict[str, object]:
    return {
        "label": label,
        "jac_sparsity_nnz": jac_sparsity_nnz,
        "format": COMPILED_FORMAT,
        "key": entry.key,
        "sha256": library_sha256,
        "n_u": entry.n_u,
        "n_y": entry.n_y,
        "functions": [entry.jacobian_name, entry.hessian_name],
        "compiler": compiler.path,
        "compiler_version": compiler.version,
        "flags": list(compiler.flags),
    }


def load_compiled(entry: CompiledEntry) -> tuple[ca.Function, ca.Function] | None:
    """J and H from the compiled entry, None unless the manifest is this entry's and the library's
    bytes match it (checked before the library is opened) and the functions have the knot's
    shapes and carry their Jacobian sparsity."""
    try:
        manifest = json.loads(entry.manifest.read_text(encoding="utf-8"))
        data = entry.library.read_bytes()
    except (OSError, ValueError):
        return None
    if not isinstance(manifest, dict):
        return None
    expected = {"format": COMPILED_FORMAT, "key": entry.key, "n_u": entry.n_u, "n_y": entry.n_y,
                "functions": [entry.jacobian_name, entry.hessian_name]}
    if any(manifest.get(k) != v for k, v in expected.items()):
        return None
    if manifest.get("sha256") != hashlib.sha256(data).hexdigest():
        return None
    try:
        jacobian = ca.external(entry.jacobian_name, str(entry.library))
        hessian = ca.external(entry.hessian_name, str(entry.library))
    except RuntimeError:
        return None
    n_u, n_y = entry.n_u, entry.n_y
    shapes_ok = (
        jacobian.n_in() == 1 and jacobian.n_out() == 1 and hessian.n_in() == 2
        and hessian.n_out() == 1
        and jacobian.size_in(0) == (n_u, 1) and jacobian.size_out(0) == (n_y, n_u)
        and hessian.size_in(0) == (n_u, 1) and hessian.size_in(1) == (n_y, 1)
        and hessian.size_out(0) == (n_u, n_u)
    )
    # the Jacobian sparsity the library carries (a library without it reports dense patterns)
    if not shapes_ok or manifest.get("jac_sparsity_nnz") != _jac_sparsity_nnz(jacobian, hessian):
        return None
    return jacobian, hessian


def _jac_sparsity_nnz(jacobian: ca.Function, hessian: ca.Function) -> list[int]:
    """Non-zeros of ∂J/∂u, ∂H/∂u and ∂H/∂λ (structural)."""
    return [jacobian.jac_sparsity(0, 0).nnz(), hessian.jac_sparsity(0, 0).nnz(),
            hessian.jac_sparsity(0, 1).nnz()]


def _renamed(function: ca.Function, name: str) -> ca.Function:
    """The SX `function` under another name (the library's exported symbol)."""
    sx_in = function.sx_in()
    return ca.Function(
        name, sx_in, function.call(sx_in),
        [function.name_in(i) for i in range(function.n_in())],
        [function.name_out(i) for i in range(function.n_out())],
    )


def compile_jacobian_and_hessian(
    entry: CompiledEntry, jacobian: ca.Function, hessian: ca.Function, compiler: Compiler,
    label: str = "",
) -> tuple[ca.Function, ca.Function]:
    """Generate C for the SX `jacobian` and `hessian` (with their Jacobian sparsity), compile it
    into `entry.library` (atomically) and load it; `label` (the robot's name) goes into the
    manifest for ``gaitsmith cache``. Raises `CompileError` (and leaves no file at
    the entry's paths) if the compiler fails or times out; `OutputWriteError` if the cache folder
    cannot be written."""
    folder = entry.library.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=".knot-compile-", dir=folder))
    except OSError as exc:
        raise OutputWriteError(f"{folder}: cannot write the knot derivative cache ({exc})") from exc
    try:
        generator = ca.CodeGenerator(f"knot_{entry.key}", {"with_header": False})
        generator.add(_renamed(jacobian, entry.jacobian_name), True)
        generator.add(_renamed(hessian, entry.hessian_name), True)
        source = Path(generator.generate(str(work) + os.sep))
        library = work / entry.library.name
        command = [compiler.path, *compiler.flags, "-fPIC", "-shared", str(source), "-o",
                   str(library), "-lm"]
        try:
            run = subprocess.run(command, capture_output=True, text=True,
                                 timeout=COMPILE_TIMEOUT_S, check=False)
        except subprocess.TimeoutExpired as exc:
            raise CompileError(
                f"{compiler.path} did not compile the knot derivatives within "
                f"{COMPILE_TIMEOUT_S:.0f} s; using the uncompiled ones"
            ) from exc
        except OSError as exc:
            raise CompileError(f"cannot run the C compiler {compiler.path}: {exc}") from exc
        if run.returncode != 0:
            last = (run.stderr.strip().splitlines() or ["(no message)"])[-1]
            raise CompileError(
                f"{compiler.path} {' '.join(compiler.flags)} failed on the knot derivatives "
                f"(exit {run.returncode}): {last}"
            )
        data = library.read_bytes()
        os.replace(library, entry.library)  # same folder: atomic
        manifest = _manifest(entry, hashlib.sha256(data).hexdigest(), compiler,
                             _jac_sparsity_nnz(jacobian, hessian), label)
        atomic_write_bytes(entry.manifest, json.dumps(manifest, indent=1).encode("utf-8"))
    except OSError as exc:
        raise OutputWriteError(f"{folder}: cannot write the compiled knot derivatives ({exc})"
                               ) from exc
    finally:
        shutil.rmtree(work, ignore_errors=True)
    loaded = load_compiled(entry)
    if loaded is None:
        raise CompileError(f"{entry.library}: the library just compiled does not load")
    return loaded

"""Per-knot derivatives for the un-expanded NLP (issue #16, "build once, reuse").

With ``expand=True`` `nlpsol` expands the whole NLP to SX and differentiates it: the Jacobian and
the Lagrangian Hessian are N copies of one knot's (1.84M instructions at N = 12 against 152K for
one knot) and building them is most of a planner's build time. With ``expand=False`` CasADi's MX
AD calls the knot function's directional derivatives instead (``fwd<n>_knot``, ``adj1_knot`` and
``fwd<n>_adj1_knot``, mapped over the knots), but it generates each of them as an SX sweep over n
directions — 576K instructions for ``fwd64_knot`` — so it builds slowly and solves slowly.

`with_knot_derivatives` gives the knot function those derivatives from one sparse Jacobian
``J(u)`` and one Lagrangian Hessian ``H(u, λ) = ∇²(λᵀ knot(u))`` of a single knot:

- ``fwd<n>_knot``:       (u, seeds Δu) ↦ J(u)·Δu
- ``adj1_knot``:         (u, λ) ↦ J(u)ᵀ·λ
- ``fwd<n>_adj1_knot``:  (u, λ, Δu, Δλ) ↦ H(u, λ)·Δu + J(u)ᵀ·Δλ

(the exact derivatives, not approximations; ``fwd<n>_adj1_knot`` skips J when Δλ is exactly
zero, which it is whenever the NLP is linear in the knot's outputs: quad12 N = 30, 43 → 35 ms
of CPU per Hessian, docs/results/planner_speed_threads.md), prepopulated into the function
cache CasADi looks them up in (`casadi.Function` option ``cache``), for every n up to
`MAX_DIRECTIONS` (CasADi's MX AD batches at most 64 directions). J and H are SX functions of
one knot, built once per robot whatever N is.

J and H are built in the process that plans (`jacobian_and_hessian`: 0.25 s for quad12, 0.7 s for
humanoid20 on a quiet 2-core machine). Until session 26 they were also kept on disk as serialised
SX, but reading that entry back took 1.2–1.6× as long as building them again
(docs/results/planner_speed_startup.md), so only what does pay is cached
(``$GAITSMITH_CACHE`` or ``~/.cache/gaitsmith/``): the direction counts a solver of this knot, N
and options used (`directions_path`, a small JSON file) and the compiled library of J and H if one
was built (`planner.nlp.compiled_knot`; a "knot" build that finds none starts its compile in
the background, `planner.nlp.background_compile`). Both are keyed by `knot_cache_key`: the knot
function's own serialised form (which is the robot's model: masses, inertias, kinematics, feet —
and nothing else enters J or H) and the casadi and gaitsmith versions; an unreadable, corrupt or
mismatching entry is rebuilt and replaced, never trusted.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata as importlib_metadata
from pathlib import Path
from typing import Any

import casadi as ca

from planner.nlp import background_compile, compiled_knot
from planner.nlp.assembled_jacobian import KnotCall
from robots.errors import OutputWriteError
from robots.files import atomic_write_bytes

#: CasADi's MX AD propagates at most this many directions at once (option ``max_num_dir``)
MAX_DIRECTIONS = 64


@dataclass(frozen=True, eq=False)
class KnotDerivatives:
    """The knot function with its derivatives prepopulated, and what keeps them alive.

    CasADi's function cache holds weak references: the derivative functions stay in it only while
    `keep_alive` does.
    """

    knot: ca.Function
    jacobian: ca.Function  # u ↦ J(u), u = every knot input stacked
    hessian: ca.Function  # (u, λ) ↦ H(u, λ), λ one multiplier per knot output row
    keep_alive: tuple[ca.Function, ...]


def stacked(values: list[Any]) -> Any:
    return ca.vertcat(*[ca.vec(v) for v in values])


def jacobian_and_hessian(knot: ca.Function) -> tuple[ca.Function, ca.Function]:
    """SX functions J(u) and H(u, λ) of one knot (u: the knot's inputs stacked, λ: its outputs')."""
    sx_in = knot.sx_in()
    u = stacked(sx_in)
    y = stacked(knot.call(sx_in))
    lam = ca.SX.sym("lam", y.shape[0])
    jac = ca.Function(f"J_{knot.name()}", [u], [ca.jacobian(y, u)], ["u"], ["J"])
    hess = ca.Function(
        f"H_{knot.name()}", [u, lam], [ca.hessian(ca.dot(lam, y), u)[0]], ["u", "lam"], ["H"]
    )
    return jac, hess


ALL_DIRECTIONS = tuple(range(1, MAX_DIRECTIONS + 1))


def with_knot_derivatives(
    knot: ca.Function,
    jacobian: ca.Function | None = None,
    hessian: ca.Function | None = None,
    forward: tuple[int, ...] = ALL_DIRECTIONS,
    second: tuple[int, ...] = ALL_DIRECTIONS,
) -> KnotDerivatives:
    """A copy of the SX `knot` function whose forward/adjoint derivatives are J·Δu, Jᵀ·λ and
    H·Δu + Jᵀ·Δλ (module docstring). `jacobian`/`hessian`: J and H already built or loaded
    (`jacobian_and_hessian` signature), e.g. compiled ones; built here otherwise.
    `forward`/`second`: the direction counts n to provide ``fwd<n>_knot`` / ``fwd<n>_adj1_knot``
    for (`used_directions` of an earlier build); CasADi generates any other one itself (exact,
    only slower), so a short list is never wrong."""
    if jacobian is None or hessian is None:
        jacobian, hessian = jacobian_and_hessian(knot)
    n_in, n_out = knot.n_in(), knot.n_out()
    names_in = [knot.name_in(i) for i in range(n_in)]
    names_out = [knot.name_out(i) for i in range(n_out)]
    sp_in = [knot.sparsity_in(i) for i in range(n_in)]
    sp_out = [knot.sparsity_out(i) for i in range(n_out)]
    for i, sp in enumerate(sp_in + sp_out):
        if not sp.is_dense():
            raise ValueError(f"knot function {knot.name()}: argument {i} is not dense")

    def syms(prefix: str, names: list[str], sps: list[ca.Sparsity]) -> list[Any]:
        return [ca.MX.sym(prefix + n, sp) for n, sp in zip(names, sps, strict=True)]

    def empty(sps: list[ca.Sparsity], n_dir: int = 1) -> list[ca.Sparsity]:
        return [ca.Sparsity(sp.size1(), sp.size2() * n_dir) for sp in sps]

    def seeds(values: list[Any], sps: list[ca.Sparsity], n_dir: int) -> Any:
        """n_dir seeds per argument (argument i: rows_i × cols_i·n_dir) → Σnumel × n_dir."""
        return ca.vertcat(
            *[ca.reshape(v, sp.numel(), n_dir) for v, sp in zip(values, sps, strict=True)]
        )

    def split(matrix: Any, sps: list[ca.Sparsity], n_dir: int) -> list[Any]:
        out, row = [], 0
        for sp in sps:
            block = matrix[row : row + sp.numel(), :]
            block = ca.reshape(block, sp.size1(), sp.size2() * n_dir)
            # CasADi expects dense derivatives of dense arguments; J or H can leave rows of
            # them structurally zero (the flat foot's knot ignores the other legs' joints)
            out.append(block if block.sparsity().is_dense() else ca.densify(block))
            row += sp.numel()
        return out

    def forward_function(
        name: str,
        arguments: tuple[list[str], list[ca.Sparsity]],
        results: tuple[list[str], list[ca.Sparsity]],
        n_dir: int,
        sensitivity: Callable[[list[Any], list[Any]], Any],
    ) -> ca.Function:
        """CasADi's forward-derivative signature of a function (`arguments` → `results`, names
        and sparsities): (nominal arguments, nominal results [empty], n_dir seeds per argument)
        ↦ sensitivities; `sensitivity(nominal, seeds)` gives them stacked (Σnumel × n_dir).
        Arguments without non-zeros (the nominal results of an adjoint) get empty seeds."""
        names_in, sps_in = arguments
        names_out, sps_out = results
        nominal = syms("", names_in, sps_in)
        outputs = syms("out_", names_out, empty(sps_out))
        seed_sps = [
            ca.Sparsity.dense(sp.size1(), sp.size2() * n_dir) if sp.nnz() else empty([sp], n_dir)[0]
            for sp in sps_in
        ]
        fwd = syms("fwd_", names_in, seed_sps)
        return ca.Function(
            name,
            nominal + outputs + fwd,
            split(sensitivity(nominal, fwd), sps_out, n_dir),
            names_in + [f"out_{n}" for n in names_out] + [f"fwd_{n}" for n in names_in],
            [f"fwd_{n}" for n in names_out],
        )

    # adj1_knot: (u, out_y [empty], adj_y) -> adj_u = Jᵀ·adj_y
    adj_name = f"adj1_{knot.name()}"
    adj_names_in = names_in + [f"out_{n}" for n in names_out] + [f"adj_{n}" for n in names_out]
    adj_names_out = [f"adj_{n}" for n in names_in]
    adj_sp_in = sp_in + empty(sp_out) + sp_out

    def second_order(n_dir: int) -> Callable[[list[Any], list[Any]], Any]:
        def sensitivity(nominal: list[Any], fwd: list[Any]) -> Any:
            u, lam = stacked(nominal[:n_in]), stacked(nominal[n_in + n_out :])
            du = seeds(fwd[:n_in], sp_in, n_dir)
            dlam = seeds(fwd[n_in + n_out :], sp_out, n_dir)
            h_du = ca.mtimes(hessian(u, lam), du)
            # Δλ is often exactly zero (the NLP is linear in the knot's outputs): J(u) is then
            # not evaluated at all (a short-circuit switch)
            jt_dlam = ca.if_else(
                ca.norm_inf(dlam) == 0, ca.MX.zeros(h_du.sparsity()),
                ca.mtimes(jacobian(u).T, dlam), True,
            )
            return h_du + jt_dlam

        return sensitivity

    def first_order(n_dir: int) -> Callable[[list[Any], list[Any]], Any]:
        def sensitivity(nominal: list[Any], fwd: list[Any]) -> Any:
            return ca.mtimes(jacobian(stacked(nominal)), seeds(fwd, sp_in, n_dir))

        return sensitivity

    adj_cache = {
        f"fwd{n}_{adj_name}": forward_function(
            f"fwd{n}_{adj_name}", (adj_names_in, adj_sp_in), (adj_names_out, sp_in), n,
            second_order(n),
        )
        for n in second
    }
    nominal = syms("", adj_names_in, adj_sp_in)
    adj_u = ca.mtimes(jacobian(stacked(nominal[:n_in])).T, stacked(nominal[n_in + n_out :]))
    adjoint = ca.Function(
        adj_name, nominal, split(adj_u, sp_in, 1), adj_names_in, adj_names_out,
        {"cache": adj_cache},
    )
    # fwd<n>_knot: (u, out_y [empty], fwd_u) -> fwd_y = J·fwd_u
    cache: dict[str, ca.Function] = {adj_name: adjoint}
    for n in forward:
        name = f"fwd{n}_{knot.name()}"
        cache[name] = forward_function(
            name, (names_in, sp_in), (names_out, sp_out), n, first_order(n)
        )
    sx_in = knot.sx_in()
    new = ca.Function(
        knot.name(), sx_in, knot.call(sx_in), names_in, names_out, {"cache": cache}
    )
    keep = (adjoint, *cache.values(), *adj_cache.values())
    return KnotDerivatives(new, jacobian, hessian, keep)


#: the solver's derivative functions whose calls `used_directions` looks through
DERIVATIVE_FUNCTIONS = ("nlp_jac_g", "nlp_hess_l", "nlp_grad_f")


def called_functions(solver: ca.Function) -> tuple[str, ...]:
    """The names of the functions `solver`'s Jacobian, Hessian and gradient functions call
    (`DERIVATIVE_FUNCTIONS`), as CasADi lists them (``Function.get_function()``: the MX
    function's call nodes). Listing them is ≈ 0.1 ms; walking the functions' instructions for
    their call nodes in Python, as this did until session 29, took 6 ms (quad12) to 21 ms
    (humanoid20) per knot function asked about (docs/results/planner_speed_startup.md)."""
    names: list[str] = []
    for name in DERIVATIVE_FUNCTIONS:
        try:
            function = solver.get_function(name)
        except RuntimeError:
            continue
        names.extend(function.get_function())
    return tuple(names)


def used_directions(solver: ca.Function, knot_name: str) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The direction counts n of the knot derivatives `solver` calls: ``fwd<n>_map<N>_knot``
    (CasADi maps ``fwd<n>_knot``) and ``fwd<n>_adj1_map<N>_knot``, found in its Jacobian,
    Hessian and gradient functions."""
    knot = re.escape(knot_name)
    forward_name = re.compile(rf"fwd(\d+)_(?:threadmap\d+_)?(?:map\d+_)?{knot}")
    second_name = re.compile(rf"fwd(\d+)_adj1_(?:threadmap\d+_)?(?:map\d+_)?{knot}")
    forward: set[int] = set()
    second: set[int] = set()
    for called in called_functions(solver):
        for pattern, found in ((forward_name, forward), (second_name, second)):
            match = pattern.fullmatch(called)
            if match:
                found.add(int(match.group(1)))
    return tuple(sorted(forward)), tuple(sorted(second))


#: part of every cache key (the compiled library's, the direction counts'): bump to orphan them
CACHE_FORMAT = "knot-derivatives-1"
#: bump when the NLP's use of the knot changes the direction counts its solver asks for (a
#: stale file only costs speed: CasADi generates a missing count itself); 2: the objective's ω
#: and the base x, y outside the knot (docs/results/planner_speed_threads.md)
DIRECTIONS_FORMAT = 2


def cache_dir() -> Path:
    """Where cached knot derivatives live: ``$GAITSMITH_CACHE`` or ``~/.cache/gaitsmith``."""
    env = os.environ.get("GAITSMITH_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "gaitsmith"


@contextmanager
def cache_folder(path: str | Path | None) -> Iterator[None]:
    """``$GAITSMITH_CACHE`` (`cache_dir`) set to `path` (None: unchanged) while the block runs,
    then put back as it was (benchmarks building planners into caches of their own)."""
    before = os.environ.get("GAITSMITH_CACHE")
    if path is not None:
        os.environ["GAITSMITH_CACHE"] = str(path)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("GAITSMITH_CACHE", None)
        else:
            os.environ["GAITSMITH_CACHE"] = before


@functools.cache
def _gaitsmith_version() -> str:
    """The installed package's version (looked up once per process: a build asks for it per
    cache key; `importlib.metadata` scans the path's distributions each time)."""
    from planner.nlp.metadata import distribution_version

    try:
        return distribution_version("gaitsmith")
    except importlib_metadata.PackageNotFoundError:
        return "unknown"


#: the last knot function hashed and the SHA-256 of its serialised form (a build asks for the
#: key three times; serialising and hashing a robot's knot costs ~0.1 s each). Holding the
#: function keeps its identity unique; CasADi functions are immutable.
_last_digest: list[tuple[ca.Function, bytes]] = []


def _knot_digest(knot: ca.Function) -> bytes:
    if not (_last_digest and _last_digest[0][0] is knot):
        _last_digest[:] = [(knot, hashlib.sha256(knot.serialize().encode()).digest())]
    return _last_digest[0][1]


def knot_cache_key(knot: ca.Function) -> str:
    """Hex key of the knot's J and H: its serialised SX graph (robot model), casadi and gaitsmith
    versions and `CACHE_FORMAT`."""
    digest = hashlib.sha256()
    for part in (CACHE_FORMAT, ca.CasadiMeta.version(), _gaitsmith_version()):
        digest.update(part.encode() + b"\0")
    digest.update(_knot_digest(knot))
    return digest.hexdigest()[:32]


@dataclass(frozen=True)
class CacheOutcome:
    """Where a planner's J and H came from: "built" (SX, built in this process; `path` None),
    or the compiled library at `path` (`planner.nlp.compiled_knot`; `compiled` True): "hit"
    (loaded), "built" (compiled now) or "rebuilt" (a corrupt or foreign entry replaced)."""

    path: Path | None
    status: str
    compiled: bool = False


def built_jacobian_and_hessian(knot: ca.Function) -> tuple[ca.Function, ca.Function, CacheOutcome]:
    """J and H of one knot built now (`jacobian_and_hessian`): faster than reading them back
    from a serialised copy (module docstring)."""
    return (*jacobian_and_hessian(knot), CacheOutcome(None, "built"))


def directions_path(
    knot: ca.Function, n_knots: int, options: object, directory: Path | None = None
) -> Path:
    """Where the direction counts a solver of this knot, N and options used are kept: they
    depend on the NLP's sparsity (N, options), so the key holds them besides the knot's."""
    digest = hashlib.sha256(
        f"{knot_cache_key(knot)}\0{n_knots}\0{options!r}\0{DIRECTIONS_FORMAT}".encode()
    ).hexdigest()[:32]
    return (directory or cache_dir()) / f"directions-{digest}.json"


def load_directions(path: Path) -> tuple[tuple[int, ...], tuple[int, ...]] | None:
    """(forward, second) direction counts stored at `path`, None if missing or not valid."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        forward, second = data["forward"], data["second"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    lists = (forward, second)
    if not all(
        isinstance(v, list) and all(type(n) is int and 1 <= n <= MAX_DIRECTIONS for n in v)
        for v in lists
    ):
        return None
    return tuple(forward), tuple(second)


def save_directions(path: Path, forward: tuple[int, ...], second: tuple[int, ...]) -> None:
    """Store the direction counts (atomically; a read-only cache folder is not an error)."""
    text = json.dumps({"format": CACHE_FORMAT, "forward": list(forward), "second": list(second)})
    try:
        atomic_write_bytes(path, text.encode("utf-8"))
    except OutputWriteError:
        pass


def knot_compiled_entry(
    knot: ca.Function, compiler: compiled_knot.Compiler, directory: Path | None = None
) -> compiled_knot.CompiledEntry:
    """Where the compiled J and H of `knot` by `compiler` live in the cache (`directory`, default
    `cache_dir`) and what the library must hold."""
    n_u = sum(knot.sparsity_in(i).numel() for i in range(knot.n_in()))
    n_y = sum(knot.sparsity_out(i).numel() for i in range(knot.n_out()))
    return compiled_knot.compiled_entry(
        knot_cache_key(knot), compiler, directory or cache_dir(), n_u, n_y
    )


def compiled_jacobian_and_hessian(
    knot: ca.Function,
    directory: Path | None = None,
    compiler: compiled_knot.Compiler | None = None,
    label: str = "",
) -> tuple[ca.Function, ca.Function, CacheOutcome]:
    """The compiled J and H of one knot (`planner.nlp.compiled_knot`): loaded from the cache, or
    compiled now (minutes) from J and H built now if missing or not intact. A background compile
    of the same entry (`planner.nlp.background_compile`) is waited for first, and its library
    loaded if it left one. `compiler`: default the one `compiled_knot.find_compiler` finds with
    the default flags; `label`: the robot's name, for the manifest. Raises `CompileError` (no
    compiler, the compiler failed) or `OutputWriteError` (cache folder not writable)."""
    compiler = compiler or compiled_knot.find_compiler()
    if compiler is None:
        raise compiled_knot.CompileError(
            "no C compiler found (gcc, cc or $GAITSMITH_CC) to compile the knot derivatives"
        )
    entry = knot_compiled_entry(knot, compiler, directory)
    loaded = compiled_knot.load_compiled(entry)
    busy = background_compile.running(entry) if loaded is None else None
    if busy is not None:
        print(f"gaitsmith: waiting for the background compile of these knot derivatives (pid "
              f"{busy.pid}, log: {busy.log})", file=sys.stderr, flush=True)
        background_compile.wait_for(entry, compiled_knot.COMPILE_TIMEOUT_S)
        loaded = compiled_knot.load_compiled(entry)
    if loaded is not None:
        return (*loaded, CacheOutcome(entry.library, "hit", compiled=True))
    status = "rebuilt" if entry.library.exists() or entry.manifest.exists() else "built"
    jacobian, hessian = jacobian_and_hessian(knot)
    jacobian, hessian = compiled_knot.compile_jacobian_and_hessian(
        entry, jacobian, hessian, compiler, label
    )
    background_compile.clear_attempts(entry)
    return jacobian, hessian, CacheOutcome(entry.library, status, compiled=True)


def knot_jacobian_and_hessian(
    knot: ca.Function, derivatives: str = "knot", directory: Path | None = None,
    label: str = "", start_compile: bool = True,
) -> tuple[ca.Function, ca.Function, CacheOutcome]:
    """J and H of one knot for the planner path `derivatives` (`PlannerOptions.derivatives`):

    - "knot": the compiled entry (`planner.nlp.compiled_knot`) if the cache holds one for the C
      compiler found and the default flags, else J and H built now (`built_jacobian_and_hessian`)
      — and, if there is a C compiler, the compile started in a detached background process for
      the next command (`planner.nlp.background_compile.start`; `label`, the robot's name, is
      what it says it compiles; not if `start_compile` is False). Never waits for a compiler.
    - "compiled": the compiled entry, compiled now (minutes) if missing or not intact; with no C
      compiler or a failed compile, a one-line warning and J and H built now.
    """
    compiler = compiled_knot.find_compiler()
    if compiler is not None and derivatives != "compiled":
        entry = knot_compiled_entry(knot, compiler, directory)
        loaded = compiled_knot.load_compiled(entry)
        if loaded is not None:
            return (*loaded, CacheOutcome(entry.library, "hit", compiled=True))
        if start_compile:
            background_compile.start(knot, entry, compiler, label)
    if derivatives == "compiled":
        try:
            return compiled_jacobian_and_hessian(knot, directory, compiler, label)
        except (compiled_knot.CompileError, OutputWriteError) as exc:
            compiled_knot.warn(f"{exc}; planning with the uncompiled knot derivatives")
    return built_jacobian_and_hessian(knot)


def same_function(fn: ca.Function) -> ca.Function:
    """`fn` itself: the NLP's per-knot functions without derivatives of their own."""
    return fn


def call_mapped(
    derived: Callable[[ca.Function], ca.Function], fn: ca.Function, n_knots: int, *args: Any
) -> tuple[Any, ...]:
    """`derived(fn)` mapped over `n_knots` knots and called with `args`: its outputs. A `derived`
    that records calls (`DerivedFunctions.record_call`) is told the call, so the assembled
    Hessian can differentiate through it (`planner.nlp.assembled_hessian`)."""
    outputs = derived(fn).map(n_knots)(*args)
    outputs = (outputs,) if isinstance(outputs, ca.MX) else tuple(outputs)
    record = getattr(derived, "record_call", None)
    if record is not None:
        record(fn.name(), KnotCall(tuple(args), outputs))
    return outputs


class DerivedFunctions:
    """The knot's treatment for the NLP's other per-knot SX functions (issue #16, session 26b).

    Called with such a function (the flat feet's ``flat_knot``, the soles' rotations ``soles``:
    `planner.nlp.constraints.build_groups`' `derived`), it returns the copy `with_knot_derivatives`
    makes of it, so IPOPT's Hessian evaluates their H·Δu + Jᵀ·Δλ instead of the SX sweeps CasADi
    generates (humanoid20: ``fwd39_adj1_flat_knot`` 173K instructions against 8.6K + 7.2K for
    H and J). Their direction counts are kept like the knot's (`directions_path` of each
    function, N and options; every count up to `MAX_DIRECTIONS` until one is recorded).
    Mutable: it holds what it made (CasADi's derivative cache holds weak references) until
    `save_used` records the counts the solver used.
    """

    def __init__(self, n_knots: int, options: object, directory: Path | None = None) -> None:
        self._n_knots = n_knots
        self._options = options
        self._directory = directory
        self.made: list[tuple[str, KnotDerivatives, Path, tuple[tuple[int, ...], ...] | None]] = []
        #: each made function's call in the NLP (`call_mapped`), for the assembled Hessian
        self.calls: list[tuple[KnotCall, ca.Function, ca.Function]] = []
        # the assembled Hessian (`PlannerOptions.nlp_hessian`) calls their H itself, never
        # their second-order directions (CasADi would generate any it asked for)
        self._second = () if getattr(options, "nlp_hessian", "ad") == "assembled" else None

    def __call__(self, fn: ca.Function) -> ca.Function:
        path = directions_path(fn, self._n_knots, self._options, self._directory)
        known = load_directions(path)
        forward, second = known or (
            ALL_DIRECTIONS, ALL_DIRECTIONS if self._second is None else self._second
        )
        made = with_knot_derivatives(fn, forward=forward, second=second)
        self.made.append((fn.name(), made, path, known))
        return made.knot

    def record_call(self, name: str, call: KnotCall) -> None:
        """`call_mapped` called the function made last for `name` with `call`."""
        made = [m for n, m, _, _ in self.made if n == name][-1]
        self.calls.append((call, made.jacobian, made.hessian))

    def save_used(self, solver: ca.Function) -> None:
        """Record the direction counts `solver` used of each function made (if new)."""
        for name, _, path, known in self.made:
            used = used_directions(solver, name)
            if used != known and (used[0] or used[1]):
                save_directions(path, *used)

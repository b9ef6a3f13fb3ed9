"""The one project-wide Numba policy: cached, no fastmath (bit-reproducible results)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from numba import njit, typeof
from numba.core.dispatcher import Dispatcher

F = TypeVar("F", bound=Callable[..., Any])


def kernel(
    function: F | None = None, *, parallel: bool = False, inline: bool = False, nrt: bool = True
) -> Any:
    """Compile ``function`` with the project's Numba options.

    ``cache=True`` keeps compiled code between runs; ``fastmath`` stays off so that
    reductions and transcendental functions are identical on every run and thread count.
    ``inline=True`` inlines the function into its Numba callers (for the small per-event
    helpers: a call that passes arrays costs reference counting, ~10 ns, more than they do).
    Numba types an inlined function anew at each call site, so a large helper, or one with
    several call sites, is compiled once as its own ``nrt=False`` function instead: a call
    from one ``nrt=False`` function to another counts no references (the quickstart's
    kernels compiled in 19 s instead of 29 s when the exact ramp, the thinning step, the
    cumulative hazard and its inverse stopped being inlined; run time unchanged, measured
    2026-11-28).
    ``nrt=False`` compiles without Numba's reference counting, for functions that allocate
    nothing and return no array: each array argument and view otherwise costs two atomic
    updates per call, a fifth of the chain kernel's run time before the event loop, the
    reset cascade and the cluster segments were compiled this way. Numba refuses an
    allocation in such a function at compile time.
    """

    def wrap(inner: F) -> F:
        return njit(
            cache=True,
            fastmath=False,
            nogil=True,
            parallel=parallel,
            inline="always" if inline else "never",
            _nrt=nrt,
        )(inner)

    return wrap if function is None else wrap(function)


def cached(dispatcher: Dispatcher, arguments: tuple[Any, ...]) -> bool:
    """Whether ``dispatcher`` has machine code in Numba's cache for its current source and
    the types of ``arguments``, so that a call with them loads rather than compiles (reads
    the cache index only; any failure to read it counts as not cached)."""
    try:
        signature = tuple(typeof(argument) for argument in arguments)
        index = dispatcher._cache._cache_file._load_index()
        return any(key[0] == signature for key in index)
    except Exception:  # a private Numba API: whatever fails to read counts as cold
        return False

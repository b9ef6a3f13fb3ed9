"""The one project-wide Numba policy: cached, no fastmath (bit-reproducible results)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from numba import njit

F = TypeVar("F", bound=Callable[..., Any])


def kernel(function: F | None = None, *, parallel: bool = False, inline: bool = False) -> Any:
    """Compile ``function`` with the project's Numba options.

    ``cache=True`` keeps compiled code between runs; ``fastmath`` stays off so that
    reductions and transcendental functions are identical on every run and thread count.
    ``inline=True`` inlines the function into its Numba callers (for the small per-event
    helpers: a call that passes arrays costs reference counting, ~10 ns, more than they do).
    """

    def wrap(inner: F) -> F:
        return njit(
            cache=True,
            fastmath=False,
            nogil=True,
            parallel=parallel,
            inline="always" if inline else "never",
        )(inner)

    return wrap if function is None else wrap(function)

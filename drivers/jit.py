"""Compiled kernels: the one place MAPR turns a Python function into machine code.

Most of MAPR's hot paths are numpy batches. A few are not expressible as a handful of array
passes without paying for twenty of them: a state machine over a stream of edges, or a
switched-mode plant stepped every 25 µs, where each step depends on the one before. Those are
written as plain loops over numpy arrays and compiled with numba's ``njit``; this module is the
only importer of numba, so the options (cached to disk, no GIL, no Python objects) are chosen
once and a kernel keeps its type signature for mypy.

Kernels are cached in ``NUMBA_CACHE_DIR`` when it is set (it then takes precedence; the
systemd unit sets it to the service's cache directory), otherwise next to their source
(``__pycache__``) or, where that is read-only, in numba's per-user cache directory. The first
call in a fresh install compiles; later processes load the cached machine code. The cache of
a kernel is keyed on its own source file only: a kernel calling a kernel of another file
keeps stale machine code when only that other file changes, so keep such call chains in one
file. Each new combination of argument types (dtype, layout, read-only flag) compiles and
caches another copy: give a kernel fresh, writable, C-ordered float64 arrays.

Example::

    from drivers.jit import kernel

    @kernel
    def count_edges(samples: np.ndarray) -> int:
        n = 0
        for i in range(1, samples.size):
            n += samples[i] != samples[i - 1]
        return n
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba
from numba.core import cgutils, types
from numba.extending import intrinsic

Function = TypeVar("Function", bound=Callable[..., Any])


def kernel(function: Function) -> Function:
    """Compile ``function`` in nopython mode, cached on disk, releasing the GIL.

    The decorated function keeps its Python signature for type checkers; at run time it is
    numba's dispatcher, which compiles once per argument-type combination.
    """
    return cast(Function, numba.njit(cache=True, nogil=True)(function))


def inline_kernel(function: Function) -> Function:
    """A :func:`kernel` compiled into each kernel that calls it rather than called.

    Small helpers called in a kernel's innermost loop (a copy of a few bytes) cost more as
    calls than as code: numba passes each array as a structure of seven fields, and a call
    keeps LLVM from optimising the loop around it. Call such a helper from kernels of its
    own file only (see the module doc on the cache).
    """
    return cast(Function, numba.njit(cache=True, nogil=True, inline="always")(function))


COPY_BLOCK = 32
"""Bytes :func:`copy_block` copies."""


@intrinsic
def _copy_block(typingctx: Any, target: Any, at: Any, source: Any, start: Any) -> Any:
    """The typing and code of :data:`copy_block`: one ``memcpy`` of a constant size, which
    LLVM turns into a couple of vector moves."""
    signature = types.void(target, at, source, start)

    def generate(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        into = context.make_array(sig.args[0])(context, builder, args[0])
        data = context.make_array(sig.args[2])(context, builder, args[2])
        cgutils.raw_memcpy(builder, builder.gep(into.data, [args[1]]),  # type: ignore[no-untyped-call]
                           builder.gep(data.data, [args[3]]),
                           context.get_constant(types.intp, COPY_BLOCK), 1)
        return context.get_dummy_value()

    return signature, generate


copy_block = cast(Callable[[Any, int, Any, int], None], _copy_block)
"""``copy_block(target, at, source, start)``, in a kernel only: copy :data:`COPY_BLOCK`
bytes of the uint8 array ``source`` from ``start`` to ``target`` at ``at``. A short text
copied whole, past its end too, costs less than a loop over its bytes of unpredictable
length; the caller leaves room past both ends. Both arrays must be C-contiguous uint8 and
both ranges inside them: nothing is checked. A kernel using it keeps its cached machine code
when only this file changes (see the module doc): clear the cache after changing it."""

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

A few operations the processor has but numba's Python cannot say are here too, as
intrinsics callable from kernels only (:data:`trailing_zeros`, :data:`population_count`,
:data:`changed_bits`, :data:`copy_block`): they are written in LLVM's terms, the level numba
compiles through, and are inlined into the kernels that call them, so the staleness above
applies to them, as it does to helpers compiled with :func:`inline_kernel`.

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
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

Function = TypeVar("Function", bound=Callable[..., Any])


def kernel(function: Function) -> Function:
    """Compile ``function`` in nopython mode, cached on disk, releasing the GIL.

    The decorated function keeps its Python signature for type checkers; at run time it is
    numba's dispatcher, which compiles once per argument-type combination.
    """
    return cast(Function, numba.njit(cache=True, nogil=True)(function))


def _uint64_to_int64(generate: Callable[[ir.IRBuilder, ir.Value], ir.Value]) -> Any:
    """A numba intrinsic taking a uint64 and returning an int64, its machine code from
    ``generate`` (LLVM builder, the argument). Only uint64 is accepted, so that a kernel
    passing another integer type fails to compile rather than count another width. The
    result is int64, not uint64, so that adding it to an int64 index stays an integer
    (numba types ``int64 + uint64`` as float64); both are LLVM's i64, so nothing converts."""

    def typed(_context: Any, value: Any) -> Any:
        if value != numba.types.uint64:
            return None  # numba then reports no matching signature

        def codegen(_ctx: Any, builder: ir.IRBuilder, _sig: Any, args: list[ir.Value]) -> Any:
            return generate(builder, args[0])

        return numba.types.int64(numba.types.uint64), codegen

    return intrinsic(typed)


trailing_zeros = cast(Callable[[np.uint64], int], _uint64_to_int64(
    lambda builder, value: builder.cttz(value, ir.Constant(ir.IntType(1), 0))))
"""The number of zero bits below the lowest set bit of a uint64 (64 for 0), as an int64;
callable from kernels only.

numba has no public count-trailing-zeros, and a bit scan written in Python terms (a de Bruijn
multiply and table) costs several instructions where the processor has one (``tzcnt``/``bsf``).
It lets a kernel turn a mask of set bits into their indices, a few instructions per set bit:
with ``word &= word - 1`` clearing the lowest. Intrinsics are inlined into the calling
kernel, so that kernel's disk cache does not see a change here (see above): clear the cache
(``__pycache__/*.nbi``/``*.nbc``) after changing one.
"""

population_count = cast(Callable[[np.uint64], int], _uint64_to_int64(
    lambda builder, value: builder.ctpop(value)))
"""The number of set bits of a uint64, as an int64; callable from kernels only (one
``popcnt`` instruction where the processor has it). With :data:`trailing_zeros`, it lets a
kernel count the flags before a set bit of a packed mask without visiting each flag.
"""


def _changed_bits_typed(_context: Any, samples: Any, start: Any, bits: Any) -> Any:
    """Typing and code generation of :data:`changed_bits` (numba's intrinsic protocol)."""
    if not (isinstance(samples, numba.types.Array) and samples.dtype == numba.types.uint8
            and samples.ndim == 1 and samples.layout == "C"
            and isinstance(start, numba.types.Integer)
            and isinstance(bits, numba.types.Integer)):
        return None  # numba then reports no matching signature

    def codegen(context: Any, builder: ir.IRBuilder, sig: Any, args: list[ir.Value]) -> Any:
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        index = context.cast(builder, args[1], sig.args[1], numba.types.intp)
        byte = ir.IntType(8)
        lanes = ir.VectorType(byte, LANES)
        here = builder.gep(data, [index])
        after = builder.gep(here, [ir.Constant(index.type, 1)])
        first = builder.load(builder.bitcast(here, lanes.as_pointer()), align=1)
        second = builder.load(builder.bitcast(after, lanes.as_pointer()), align=1)
        one = builder.trunc(context.cast(builder, args[2], sig.args[2], numba.types.int64), byte)
        spread = builder.shuffle_vector(
            builder.insert_element(ir.Constant(lanes, ir.Undefined), one,
                                   ir.Constant(ir.IntType(32), 0)),
            ir.Constant(lanes, ir.Undefined),
            ir.Constant(ir.VectorType(ir.IntType(32), LANES), [0] * LANES))
        differ = builder.and_(builder.xor(first, second), spread)
        flags = builder.icmp_unsigned("!=", differ, ir.Constant(lanes, None))
        return builder.bitcast(flags, ir.IntType(LANES))

    return numba.types.uint64(samples, start, bits), codegen


LANES = 64
"""Samples compared by one :data:`changed_bits` (one bit each of a uint64). Kernels that call
it are written for this number (:mod:`drivers.mil1553.edges` checks it at import)."""

changed_bits = cast(Callable[[Any, int, int], np.uint64], intrinsic(_changed_bits_typed))
"""``changed_bits(samples, start, bits)``: a uint64 whose bit ``k`` says
``(samples[start + k] ^ samples[start + k + 1]) & bits`` is non-zero, for ``k`` in 0-63;
callable from kernels only. ``samples`` is a C-contiguous uint8 array, and **the caller
must ensure** ``0 <= start`` and ``start + 65 <= samples.size``: the 65 bytes are read
without a bounds check.

Written as one comparison of two 64-byte vectors, so LLVM compiles it to a handful of vector
instructions (load, XOR, AND, compare, move the lanes' mask to a register: ``vpmovmskb`` with
AVX2, a mask register with AVX-512) for 64 samples, where numba's loops, element by
element, compile to one or more instructions per sample. It is how a kernel passes over a
capture's samples: the bits it returns are visited with :data:`trailing_zeros`, so the work
is per change, not per sample, with no array of flags in between.
"""


def inline_kernel(function: Function) -> Function:
    """A :func:`kernel` compiled into each kernel that calls it rather than called.

    Small helpers called in a kernel's innermost loop (a copy of a few bytes) cost more as
    calls than as code: numba passes each array as a structure of seven fields, and a call
    keeps LLVM from optimising the loop around it. Call such a helper from kernels of its
    own file only (see the module doc on the cache).
    """
    return cast(Function, numba.njit(cache=True, nogil=True, inline="always")(function))


COPY_BLOCK = 32
"""Bytes :func:`copy_block` copies. Kernels that call it are written for this number
(:mod:`mapr_daemon.cli.icdview.jsontext` checks it at import)."""


@intrinsic
def _copy_block(typingctx: Any, target: Any, at: Any, source: Any, start: Any) -> Any:
    """The typing and code of :data:`copy_block`: one ``memcpy`` of a constant size, which
    LLVM turns into a couple of vector moves. Only 1-D C-contiguous uint8 arrays and integer
    offsets are accepted (anything else: no matching signature), since the offsets are taken
    as byte offsets and nothing is checked."""
    if not (all(isinstance(a, types.Array) and a.dtype == types.uint8 and a.ndim == 1
                and a.layout == "C" for a in (target, source))
            and all(isinstance(i, types.Integer) for i in (at, start))):
        return None
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
